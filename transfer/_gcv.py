"""Choosing example-based rigging's balance ``beta`` from the examples by generalized cross-validation.

Li et al. (2010, sec. 3A) fit every triangle's blendshape edge frames by the ridge problem
``min_X |W X - R_t|^2 + beta sum_i w_ti |X_i - P_ti|^2`` and fix ``beta = 0.1`` by hand. A TD fitting a
new character has the template, the target neutral and the J training examples, not the target's
blendshapes, so the choice here uses only those: the generalized cross-validation score of Golub, Heath
and Wahba (1979), pooled over all the per-triangle systems.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: Grid points per decade of ``beta`` before the refinement.
_PER_DECADE = 4
#: Width, in decades, to which the refinement narrows the minimiser of the score.
_DECADE_TOLERANCE = 0.01


@dataclass(frozen=True)
class Spectra:
    """The data of a set of per-triangle ridge systems, reduced to what ``beta`` acts on.

    With ``Delta = X - P_t``, ``y_t = R_t - W P_t`` and ``D_t = diag(w_t)`` the fitted values of one
    triangle are ``H_t y_t`` with the hat matrix ``H_t = G_t (G_t + beta I)^-1``,
    ``G_t = W D_t^-1 W^T`` (J x J, the Woodbury form of `transfer.ebfr.fit_edge_frames`). With the
    eigendecomposition ``G_t = U diag(g) U^T``, ``I - H_t = U diag(beta / (g + beta)) U^T``: one
    eigenvalue ``g`` and one energy ``z = |U^T y_t|^2`` (summed over the 6 edge coordinates, which
    share ``H_t``) per (triangle, eigenvector) are all any ``beta`` needs.

    Attributes
    ----------
    eigenvalues : (P,) array
        ``g >= 0`` of every (triangle, eigenvector) pair.
    energies : (P,) array
        ``z``, the matching squared residual of the prior, summed over 6 coordinates.
    parts : tuple of Spectra
        The sets of systems these pool (`join`), empty for one set.
    """

    eigenvalues: np.ndarray
    energies: np.ndarray
    parts: tuple[Spectra, ...] = ()
    #: `grid_sums` of the last grid asked for, by the grid's bytes.
    _kept: dict[bytes, np.ndarray] = field(default_factory=dict, init=False, repr=False, compare=False)

    @classmethod
    def join(cls, parts: list[Spectra]) -> Spectra:
        """The systems of all ``parts`` pooled."""
        if not parts:
            return cls(np.zeros(0), np.zeros(0))
        return cls(
            np.concatenate([part.eigenvalues for part in parts]),
            np.concatenate([part.energies for part in parts]),
            tuple(parts),
        )

    def grid_sums(self, grid: np.ndarray) -> np.ndarray:
        """``(2, B)`` sums over the pairs of ``s^2 z`` and of ``s``, ``s = beta / (g + beta)`` the diagonal
        of ``I - H`` (see `gcv_scores`), at the ``beta`` values of ``grid``, kept for the last grid.

        Pooled systems add the kept sums of their `parts`, so a part that joins several pools (an
        expression in the first J expressions for every larger J) is scored on the grid once
        (`_looped_sums`).
        """
        key = grid.tobytes()
        found = self._kept.get(key)
        if found is None:
            if self.parts:
                found = sum((part.grid_sums(grid) for part in self.parts), np.zeros((2, grid.size)))
            else:
                found = _looped_sums(self, grid)
            self._kept.clear()
            self._kept[key] = found
        return found


def _looped_sums(spectra: Spectra, betas: np.ndarray) -> np.ndarray:
    """`Spectra.grid_sums` of one set of systems, the products summed by numpy's own loops rather than a
    BLAS product, whose second thread waits for a core when two harness workers share two. The grid of
    `choose_beta` only brackets the minimum, which the refinement finds with `gcv_scores`."""
    shrink = betas[:, None] / (spectra.eigenvalues[None, :] + betas[:, None])  # (B, P)
    return np.stack((np.einsum("bp,bp,p->b", shrink, shrink, spectra.energies), shrink.sum(axis=1)))


def ridge_spectra(regularisation: np.ndarray, weights: np.ndarray, residual: np.ndarray) -> Spectra:
    """`Spectra` of the per-triangle systems of `transfer.ebfr.fit_edge_frames`.

    Parameters
    ----------
    regularisation : (T, K) array
        Weights ``w_ti > 0``.
    weights : (J, K) array
        Blendshape weights of the training expressions.
    residual : (T, 6, J) array
        ``R_t - W P_t``: the training edges minus the prior's prediction of them.

    Returns
    -------
    Spectra with ``T J`` pairs.

    Notes
    -----
    One batched ``eigh``: O(T (K J^2 + J^3)). The expressions of a packing (no shape in two) are
    systems of one example each, ``g = sum_i W_i^2 / w_ti`` (`transfer._expression_fit`).
    """
    outer = (weights[:, None, :] * weights[None, :, :]).reshape(-1, weights.shape[1]).T  # (K, J*J)
    n_expressions = weights.shape[0]
    gram = ((1.0 / regularisation) @ outer).reshape(-1, n_expressions, n_expressions)
    eigenvalues, vectors = np.linalg.eigh(gram)
    energies = np.sum(np.einsum("tjk,tcj->tck", vectors, residual) ** 2, axis=1)
    return Spectra(np.maximum(eigenvalues, 0.0).ravel(), energies.ravel())


def gcv_scores(spectra: Spectra, betas: np.ndarray) -> np.ndarray:
    """Pooled GCV score of every ``beta`` (Golub, Heath & Wahba 1979, eq. 1.4).

    ``V(beta) = (|(I - H) y|^2 / n) / (tr(I - H) / n)^2`` over all ``n = 6 P`` observed edge
    coordinates of all triangle systems, with ``I - H = beta (G + beta I)^-1`` (see `Spectra`).

    Parameters
    ----------
    spectra : Spectra
    betas : (B,) array of positive numbers

    Returns
    -------
    (B,) array; all zero when nothing is observed or the prior already explains every example.
    """
    betas = np.asarray(betas, dtype=float)
    if spectra.eigenvalues.size == 0:
        return np.zeros(betas.shape)
    shrink = betas[:, None] / (spectra.eigenvalues[None, :] + betas[:, None])  # (B, P): diag of I - H
    # numpy's own loop, not a BLAS product: a threaded BLAS sums in an order that depends on its thread
    # count, which moved a chosen beta by 1e-9 between one thread and two
    products = np.einsum("bp,p->b", shrink**2, spectra.energies)
    return _scores(products, shrink.sum(axis=1), spectra.eigenvalues.size)


def _scores(products: np.ndarray, shrinkage: np.ndarray, n_pairs: int) -> np.ndarray:
    """GCV scores from the sums of ``s^2 z`` and of ``s`` over ``n_pairs`` pairs (`gcv_scores`)."""
    count = 6.0 * n_pairs
    residual = products / count
    trace = 6.0 * shrinkage / count
    return residual / trace**2


@dataclass(frozen=True)
class BetaChoice:
    """The ``beta`` chosen by GCV, with the score curve it came from (for records and plots).

    Attributes
    ----------
    beta : float
        The minimiser of the GCV score over ``[low, high]``; NaN without training expressions (then
        ``beta`` has no effect: the fit is deformation transfer).
    grid : (B,) array
        The log-spaced ``beta`` values scored first.
    scores : (B,) array
        Their GCV scores.
    score : float
        The score at ``beta``.
    """

    beta: float
    grid: np.ndarray
    scores: np.ndarray
    score: float


def choose_beta(spectra: Spectra, low: float, high: float) -> BetaChoice:
    """``beta`` in ``[low, high]`` minimising the pooled GCV score of ``spectra``.

    The score is evaluated on a log grid of `_PER_DECADE` points per decade, then the best grid point is
    refined by bounded Brent search in ``log10 beta`` between its neighbours (`scipy.optimize`) to
    `_DECADE_TOLERANCE` decades. Deterministic: no random start.

    Parameters
    ----------
    spectra : Spectra
    low, high : float
        ``0 < low <= high``.

    Returns
    -------
    BetaChoice

    Notes
    -----
    O(B P) for the grid plus O(P) per refinement step, for P (triangle, eigenvector) pairs; no fit is
    computed. Pooled spectra add the grid sums their parts keep (`Spectra.grid_sums`), so the grid
    costs O(B P') for the P' pairs of parts not scored before. GCV estimates the prediction error of
    the fitted examples without a noise level and is invariant to the units of the rig. With exact
    examples (the linear sum of the true shapes) every residual of the prior is signal, and the score
    falls towards ``low``; scanner noise and correctives that the shapes cannot explain are residuals no
    ``beta`` removes, and the score rises again as ``beta -> 0`` once fitting them costs more than it
    gains.
    """
    steps = max(2, int(np.ceil(_PER_DECADE * np.log10(high / low))) + 1) if high > low else 1
    grid = np.geomspace(low, high, steps)
    if spectra.eigenvalues.size == 0:
        return BetaChoice(float("nan"), grid, np.zeros(steps), float("nan"))
    scores = _scores(*spectra.grid_sums(grid), spectra.eigenvalues.size)
    from scipy.optimize import minimize_scalar  # importing transfer must not load scipy

    best = int(np.argmin(scores))
    if steps == 1:
        return BetaChoice(float(grid[0]), grid, scores, float(scores[0]))
    bounds = np.log10(grid[[max(best - 1, 0), min(best + 1, steps - 1)]])
    found = minimize_scalar(
        lambda exponent: float(gcv_scores(spectra, np.array([10.0**exponent]))[0]),
        bounds=tuple(bounds),
        method="bounded",
        options={"xatol": _DECADE_TOLERANCE},
    )
    beta, score = (10.0 ** float(found.x), float(found.fun))
    if score > scores[best]:
        beta, score = float(grid[best]), float(scores[best])
    return BetaChoice(beta, grid, scores, score)
