"""Example-based facial rigging in gradient space, step A (Li et al. 2010, 3A; Carrigan et al. 2020, 5)."""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar, Literal

import numpy as np

from registry import BoundedMemo
from transfer._base import Transfer, check_positive
from transfer._expression_fit import ExpressionFit, ExpressionSystem, Fitted
from transfer._frames import edge_vectors, triangle_chunks, vertex_major
from transfer._gcv import BetaChoice, Spectra, choose_beta, ridge_spectra
from transfer._inputs import TransferInputs, check_inputs
from transfer._regularisation import Regularisation
from transfer._setup import TransferSetup, transfer_setup

#: Expressions a set-up keeps, by weights, by weights and example, and fitted at one ``beta``.
_EXPRESSION_CACHE_SIZE = 512


def fit_edge_frames(
    prior: np.ndarray,
    regularisation: np.ndarray,
    weights: np.ndarray,
    observed: np.ndarray,
    beta: float,
) -> np.ndarray:
    """Blendshape edge frames that fit the training frames near a prior, for every triangle at once.

    For each triangle t solves ``min_X |W X - R_t|^2 + beta * sum_i w_ti |X_i - P_ti|^2``
    (Li et al. 2010, ``E_A = E_fit + beta E_reg``, sec. 3A) over the K edge-frame displacements X
    (rows of 6 numbers: two edges of three coordinates). With ``X = P + Delta`` the normal equations read
    ``(W^T W + D_t) Delta = W^T (R_t - W P_t)`` with ``D_t = beta diag(w_t)``, and the push-through form
    of the Woodbury identity gives

        Delta = D_t^-1 W^T (I_J + W D_t^-1 W^T)^-1 (R_t - W P_t)

    so each triangle costs one J x J solve. The form subtracts no large terms, so it stays accurate as
    ``beta -> 0``.

    Parameters
    ----------
    prior : (T, 2, 3, K) array
        Deformation-transfer edges ``M_i^{A*}`` of the target shapes.
    regularisation : (T, K) array
        Weights ``w_ti > 0`` (see `Regularisation`).
    weights : (J, K) array
        Blendshape weights of the training expressions.
    observed : (T, 2, 3, J) array
        Edge displacements of the training expressions from the target neutral.
    beta : float
        Balance of fit and regularisation; Li et al. recommend 0.1.

    Returns
    -------
    (T, 2, 3, K) array.

    Notes
    -----
    O(T (K J^2 + J^3)) time, in chunks of triangles so temporaries stay O(chunk K). A shape in no
    expression has a zero column in W, hence a zero update: it keeps the prior exactly. The expressions
    of a packing (no shape in two) are fitted one at a time in closed form instead
    (`transfer._expression_fit`).
    """
    n_triangles, n_shapes = prior.shape[0], prior.shape[-1]
    n_expressions = weights.shape[0]
    result = prior.reshape(n_triangles, 6, n_shapes).copy()
    if n_expressions == 0:
        return result.reshape(prior.shape)
    predicted = (result.reshape(-1, n_shapes) @ weights.T).reshape(n_triangles, 6, n_expressions)
    residual = observed.reshape(n_triangles, 6, n_expressions) - predicted  # (T, 6, J)
    outer = (weights[:, None, :] * weights[None, :, :]).reshape(n_expressions**2, n_shapes).T  # (K, J*J)
    identity = np.eye(n_expressions)
    for part in triangle_chunks(n_triangles, 2 * max(n_shapes, n_expressions**2)):
        inverse_diagonal = 1.0 / (beta * regularisation[part])  # (c, K)
        capacitance = identity + (inverse_diagonal @ outer).reshape(-1, n_expressions, n_expressions)
        mixed = np.linalg.solve(capacitance, residual[part].transpose(0, 2, 1))  # (c, J, 6)
        update = (mixed.transpose(0, 2, 1).reshape(-1, n_expressions) @ weights).reshape(-1, 6, n_shapes)
        result[part] += update * inverse_diagonal[:, None, :]
    return result.reshape(prior.shape)


class RiggingState:
    """What step A keeps per set-up and regularisation parameters: the weights and the fitted expressions.

    Parameters
    ----------
    setup : TransferSetup
    kappa, theta, motion_scale
        See `Regularisation`.
    """

    def __init__(self, setup: TransferSetup, kappa: float, theta: float, motion_scale: str) -> None:
        self.regularisation = Regularisation(setup, kappa, theta, motion_scale)
        #: Single expressions by weights, and with their example, at any ``beta`` (`ExpressionSystem`,
        #: `ExpressionFit`: fits and GCV spectra).
        self.systems: BoundedMemo[ExpressionSystem] = BoundedMemo(_EXPRESSION_CACHE_SIZE)
        self.fits: BoundedMemo[ExpressionFit] = BoundedMemo(_EXPRESSION_CACHE_SIZE)
        #: Fitted shapes of single expressions (`GradientSpaceRigging.blendshapes`).
        self.expressions: BoundedMemo[Fitted] = BoundedMemo(_EXPRESSION_CACHE_SIZE)
        #: Choices of ``beta`` (`GradientSpaceRigging.choose_beta`).
        self.choices: BoundedMemo[BetaChoice] = BoundedMemo(_EXPRESSION_CACHE_SIZE)


class GradientSpaceRigging:
    """Step A of example-based rigging prepared for one template, target neutral and set of examples.

    Everything that does not depend on the expression weights or the examples comes from the memoised
    `transfer_setup` (shared with deformation transfer): the aligned template, the deformation-transfer
    prior, the vertex solve and its constraints; the regularisation weights and the fitted expressions
    are kept with it (`RiggingState`). `blendshapes` may then be called with any weights and ``beta``
    (`transfer.ebfr_full` calls it once per iteration), and `prefixes` evaluates the first J expressions
    for a rising J at the cost of one fit per expression.

    Parameters
    ----------
    inputs : TransferInputs
    kappa, theta, motion_scale, static_tolerance, align
        See `ExampleBasedRigging`.

    Attributes
    ----------
    setup : TransferSetup
    state : RiggingState
    examples : (J, N, 3) array
        The training expressions.
    offsets : (N, 3, J) array
        The training expressions minus the target neutral, vertex-major.
    """

    def __init__(
        self,
        inputs: TransferInputs,
        *,
        kappa: float = 0.1,
        theta: float = 2.0,
        motion_scale: str = "peak",
        static_tolerance: float = 1e-6,
        align: bool = True,
    ) -> None:
        target = inputs.target_neutral
        self.setup = transfer_setup(inputs.template, target, static_tolerance=static_tolerance, align=align)
        self.state = self.setup.derived(
            ("ebfr", float(kappa), float(theta), motion_scale),
            lambda: RiggingState(self.setup, kappa, theta, motion_scale),
        )
        self.examples = inputs.examples
        self.offsets = vertex_major(inputs.examples - target)
        self._example_digests: dict[int, bytes] = {}

    def blendshapes(self, weights: np.ndarray, beta: float) -> np.ndarray:
        """Target deltas ``(K, N, 3)`` for expression ``weights (J, K)`` and balance ``beta``.

        Only the shapes with a nonzero weight in some expression are fitted and reconstructed: the fit
        of the others keeps the prior exactly (see `fit_edge_frames`), so they are the set-up's
        deformation transfer. When no shape is in two expressions (a packing), the fit splits into one
        independent problem per expression, each depending only on that expression's weights and
        example; those are memoised, so the sequences of J = 2, 4, 7, ... expressions of one packing fit
        each expression once.
        """
        result = self.setup.transferred.copy()
        self.apply(result, weights, beta)
        return result

    def prefixes(
        self, weights: np.ndarray, beta: float | Callable[[int], float]
    ) -> Callable[[int], np.ndarray]:
        """``blendshapes(weights[:j], beta)`` as a function of j (see `RisingPrefixes`); ``beta`` may
        be a function of j (as `choose_beta` of the first j expressions)."""
        return RisingPrefixes(self, weights, beta if callable(beta) else lambda count: beta)

    def choose_beta(self, weights: np.ndarray, low: float, high: float) -> BetaChoice:
        """``beta`` in ``[low, high]`` by generalized cross-validation of step A (`transfer._gcv`).

        Uses the template, the target neutral and the training expressions only. The per-triangle
        systems are those `blendshapes` solves: for a packing, each expression's shapes on the triangles
        around their free vertices, whose spectra are memoised per expression as the fits are; otherwise
        all covered shapes jointly. The choice is memoised per weights and examples.
        """
        digest = hashlib.blake2b(weights.tobytes(), digest_size=16)
        for j in range(weights.shape[0]):
            digest.update(self._example_digest(j))
        key = (digest.hexdigest(), float(low), float(high))
        return self.state.choices.get_or_build(key, lambda: choose_beta(self.spectra(weights), low, high))

    def spectra(self, weights: np.ndarray) -> Spectra:
        """GCV spectra of the systems `blendshapes` solves for ``weights`` (see `choose_beta`)."""
        if _disjoint(weights):
            parts = [self._fit(j, row).spectra for j, row in enumerate(weights) if row.any()]
            return Spectra.join(parts)
        covered = np.flatnonzero(np.any(weights != 0, axis=0))
        setup, joint = self.setup, weights[:, covered]
        faces = setup.faces(covered)
        observed = edge_vectors(self.offsets[..., : weights.shape[0]], setup.triangles[faces])
        prior = setup.prior.block(faces, covered).reshape(faces.size, 6, covered.size)
        residual = observed.reshape(faces.size, 6, -1) - prior @ joint.T
        return ridge_spectra(self.state.regularisation.block(faces, covered), joint, residual)

    def _fit(self, j: int, row: np.ndarray) -> ExpressionFit:
        """Expression ``j`` alone (no other expression holds its shapes) with its example, memoised."""
        return self.state.fits.get_or_build(
            self._expression_key(j, row),
            lambda: self._system(row).fit(self.setup, self.offsets[..., [j]]),
        )

    def _system(self, row: np.ndarray) -> ExpressionSystem:
        """An expression of weights ``row`` alone, for any example, memoised."""
        return self.state.systems.get_or_build(
            row.tobytes(), lambda: ExpressionSystem.build(self.setup, self.state.regularisation, row)
        )

    def apply(self, result: np.ndarray, weights: np.ndarray, beta: float, start: int = 0) -> None:
        """Write the fitted shapes of expressions ``start`` onward of ``weights`` into ``result``.

        ``result`` must hold the fit of the first ``start`` expressions already, which a packing's
        expressions (no shape in two) leave alone; otherwise every covered shape is fitted jointly and
        ``start`` is ignored.
        """
        if _disjoint(weights):
            for j in range(start, weights.shape[0]):
                if weights[j].any():
                    _write(result, self._expression(j, weights[j], beta))
        else:
            covered = np.flatnonzero(np.any(weights != 0, axis=0))
            expressions = np.arange(weights.shape[0])
            _write(result, self._fitted(weights[:, covered], covered, expressions, beta))

    def _fitted(
        self, weights: np.ndarray, shapes: np.ndarray, expressions: np.ndarray, beta: float
    ) -> Fitted:
        """Free-vertex displacements of ``shapes`` fitted to ``expressions`` whose weights on ``shapes``
        are the columns of ``weights``; only the triangles around their free vertices are evaluated."""
        setup = self.setup
        faces = setup.faces(shapes)
        observed = edge_vectors(self.offsets[..., expressions], setup.triangles[faces])
        edges = fit_edge_frames(
            setup.prior.block(faces, shapes),
            self.state.regularisation.block(faces, shapes),
            weights,
            observed,
            beta,
        )
        return list(setup.solve(shapes, faces, edges))

    def _expression(self, j: int, row: np.ndarray, beta: float) -> Fitted:
        """The shapes of expression ``j`` alone (no other expression holds them), memoised."""
        return self.state.expressions.get_or_build(
            (self._expression_key(j, row), float(beta)), lambda: self._fit(j, row).fitted(self.setup, beta)
        )

    def _expression_key(self, j: int, row: np.ndarray) -> str:
        """Digest of expression ``j``'s weights and example."""
        digest = hashlib.blake2b(row.tobytes(), digest_size=16)
        digest.update(self._example_digest(j))
        return digest.hexdigest()

    def _example_digest(self, j: int) -> bytes:
        """Digest of example ``j``, computed once per instance (every J and ``beta`` asks again)."""
        found = self._example_digests.get(j)
        if found is None:
            example = np.ascontiguousarray(self.examples[j])
            found = self._example_digests[j] = hashlib.blake2b(example.data, digest_size=16).digest()
        return found


class RisingPrefixes:
    """Step A with the first j expressions of ``weights``, for any j, updated in place while j rises.

    For a packing the estimate of J + 1 expressions is the estimate of J with the shapes of expression
    J + 1 replaced (they are in no other expression), so a rising sequence of J values costs one fit per
    expression and one copy per J. A falling j puts the shapes of the expressions it drops back to
    deformation transfer; expressions that share shapes are fitted jointly
    (`GradientSpaceRigging.blendshapes`).

    Parameters
    ----------
    rigging : GradientSpaceRigging
    weights : (J, K) array
    beta : callable
        ``beta`` for the first j expressions, as a function of j; when it changes between calls every
        expression is fitted again in place at the new ``beta`` (`transfer._expression_fit`: a scaling
        and a vertex solve each; fits already made at that ``beta`` are reused).
    """

    def __init__(
        self, rigging: GradientSpaceRigging, weights: np.ndarray, beta: Callable[[int], float]
    ) -> None:
        self.rigging = rigging
        self.weights = weights
        self.beta = beta
        self._result: np.ndarray | None = None
        self._applied = 0
        self._beta = float("nan")

    def __call__(self, count: int) -> np.ndarray:
        """``(K, N, 3)`` deltas from the first ``count`` expressions, a new array."""
        head = self.weights[:count]
        beta = self.beta(count)
        if not _disjoint(head):
            return self.rigging.blendshapes(head, beta)
        transferred = self.rigging.setup.transferred
        if self._result is None:
            self._result, self._applied = transferred.copy(), 0
        if count < self._applied:
            dropped = np.flatnonzero(np.any(self.weights[count : self._applied] != 0, axis=0))
            self._result[dropped] = transferred[dropped]
        start = min(count, self._applied) if beta == self._beta else 0
        self.rigging.apply(self._result, head, beta, start)
        self._applied, self._beta = count, beta
        return self._result.copy()


def _disjoint(weights: np.ndarray) -> bool:
    """Whether every shape is in at most one expression (a packing without extra examples)."""
    return bool(np.all(np.count_nonzero(weights, axis=0) <= 1))


def _write(result: np.ndarray, fitted: Fitted) -> None:
    """Put fitted free-vertex displacements into ``(K, N, 3)`` deltas."""
    for members, free, values in fitted:
        result[np.ix_(members, free)] = np.moveaxis(values, -1, 0)


@dataclass(frozen=True, kw_only=True)
class RiggingSettings:
    """The regularisation both rigging methods share (`ExampleBasedRigging`, step A, and
    `transfer.ebfr_full.ExampleBasedRiggingFull`, steps A and B; Li et al. 2010, sec. 3A).

    Parameters
    ----------
    kappa : float, default 0.1
        Regularisation-weight offset (Li et al. 2010, sec. 3A).
    theta : float, default 2.0
        Regularisation-weight exponent (Li et al. use 2).
    motion_scale : {"peak", "absolute"}, default "peak"
        Measure each template shape's triangle motion relative to its most active triangle (scale-free
        ``kappa``), or literally in the rig's units as Li et al. (see `Regularisation`).
    static_tolerance : float, default 1e-6
        Vertices moving at most this fraction of a template shape's largest displacement stay fixed.
    align : bool, default True
        Rotate the template to face like the target first (see `transfer.deformation`).
    """

    kappa: float = 0.1
    theta: float = 2.0
    motion_scale: str = "peak"
    static_tolerance: float = 1e-6
    align: bool = True

    def __post_init__(self) -> None:
        if self.motion_scale not in ("peak", "absolute"):
            raise ValueError(f"motion_scale must be 'peak' or 'absolute', got {self.motion_scale!r}")
        check_positive(self.kappa, "kappa")
        check_positive(self.theta, "theta", allow_zero=True)
        check_positive(self.static_tolerance, "static_tolerance", allow_zero=True)

    def rigging(self, inputs: TransferInputs) -> GradientSpaceRigging:
        """The gradient-space fit of ``inputs`` with these settings."""
        return GradientSpaceRigging(
            inputs,
            kappa=self.kappa,
            theta=self.theta,
            motion_scale=self.motion_scale,
            static_tolerance=self.static_tolerance,
            align=self.align,
        )


@dataclass(frozen=True)
class ExampleBasedRigging(RiggingSettings, Transfer):
    """Example-based facial rigging with known 0/1 weights (Li et al. 2010, step A; Carrigan et al. 2020).

    The target's blendshapes are fitted per triangle in gradient space to the training expressions,
    regularised towards deformation transfer of the template, then reconstructed as vertices with the
    template's static vertices held (Li et al. 2010, sec. 3A).

    Parameters
    ----------
    beta : float or "gcv", default "gcv"
        Weight of the regulariser ``E_reg`` against the fit ``E_fit``. ``"gcv"`` chooses it in
        ``beta_range`` for every set of training expressions by generalized cross-validation
        (`choose_beta`); a number fixes it (Li et al.'s final 0.1 balances accuracy and robustness with
        real examples: ``ebfr[beta=0.1]`` on the command line). ``beta -> infinity`` is deformation
        transfer. With every shape scanned alone and exactly (``toon``, ``alien+character``, J = K), the
        fixed 0.1 reaches only 0.685 of deformation transfer's RMS, GCV 0.004; with scan-like examples
        0.685 and 0.096.
    beta_range : (float, float), default (1e-4, 1.0)
        Interval searched by ``beta="gcv"``.
    kappa, theta, motion_scale, static_tolerance, align
        The regularisation (`RiggingSettings`).

    Examples
    --------
    >>> import transfer
    >>> method = transfer.get("ebfr", beta="gcv")
    >>> deltas = method(template, target.neutral, weights, examples)  # doctest: +SKIP
    >>> method.beta_used(template, target.neutral, weights, examples)  # doctest: +SKIP
    0.00012

    Notes
    -----
    The data term ``W^T W`` is the same for every triangle and has rank <= J, so the per-triangle systems
    are solved in one batched Woodbury step, O(T (K J^2 + J^3)) (see `fit_edge_frames`), and only on the
    triangles around the vertices the fitted shapes move. For a packing (no shape in two expressions)
    each expression is a system of one example, solved in closed form for any ``beta`` from what is kept
    per weights and per example (`transfer._expression_fit`): GCV's ``beta`` for every J refits the
    expressions without evaluating a prior again. The vertex solve costs one sparse factorisation
    per distinct set of static vertices, shared with `transfer.deformation` and kept for every later
    J and call on the same rig pair (`transfer._setup.transfer_setup`). Shapes in no training expression
    come out as deformation transfer; with J = 0 the method is deformation transfer. `prefixes` fits each
    expression of a packing once for all J at one ``beta`` (`RisingPrefixes`).

    Why GCV for ``beta="gcv"``: a TD has the template, the target neutral and the J examples, not the
    target's shapes, so ``beta`` must be judged on the examples. Hold-out validation fails there: when
    each shape is in one expression, an expression left out takes its shapes' only data with it and its
    prediction is the prior whatever ``beta`` (the leave-one-out residual ``e_j / (1 - H_jj)`` equals the
    prior's residual). Generalized cross-validation (Golub, Heath & Wahba 1979) pools the closed-form
    hat matrices of all per-triangle systems instead: triangles whose shapes may move freely (large
    ``G_t = W D_t^-1 W^T``) against those held near the prior tell signal (residuals that grow with the
    freedom) from noise (residuals that do not). It needs no noise level, unlike Morozov's discrepancy
    principle, and it reuses the Woodbury form of the fit: O(T K J) for a packing, no extra fit.
    """

    name: ClassVar[str] = "ebfr"
    binary_weights: ClassVar[bool] = True
    beta: float | Literal["gcv"] = "gcv"
    beta_range: tuple[float, float] = (1e-4, 1.0)

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.beta != "gcv":
            if isinstance(self.beta, str):
                raise ValueError(f"beta must be a positive number or 'gcv', got {self.beta!r}")
            check_positive(self.beta, "beta")
        low, high = self.beta_range
        check_positive(low, "beta_range[0]")
        check_positive(high, "beta_range[1]")
        if low > high:
            raise ValueError(f"beta_range must be (low, high) with low <= high, got {self.beta_range!r}")

    def transfer(self, inputs: TransferInputs) -> np.ndarray:
        """Step A with the given weights."""
        rigging = self.rigging(inputs)
        return rigging.blendshapes(inputs.weights, self._beta(rigging, inputs.weights))

    def _prefixes(self, inputs: TransferInputs) -> Callable[[int], np.ndarray]:
        """Step A with the first J expressions, each fitted once per ``beta`` (`RisingPrefixes`)."""
        rigging = self.rigging(inputs)
        return rigging.prefixes(inputs.weights, lambda count: self._beta(rigging, inputs.weights[:count]))

    def choose_beta(
        self, template: object, target_neutral: object, weights: object = None, examples: object = None
    ) -> BetaChoice:
        """The GCV choice of ``beta`` in ``beta_range`` for these inputs, whatever ``beta`` is.

        Parameters
        ----------
        template, target_neutral, weights, examples
            As for calling the method; never the target's blendshapes.

        Returns
        -------
        BetaChoice
            ``beta``, the GCV score curve on a log grid, and the score at ``beta`` (`transfer._gcv`);
            memoised, so asking after a ``beta="gcv"`` transfer costs nothing.
        """
        inputs = self.checked(template, target_neutral, weights, examples)
        return self.rigging(inputs).choose_beta(inputs.weights, *self.beta_range)

    def beta_used(
        self, template: object, target_neutral: object, weights: object = None, examples: object = None
    ) -> float:
        """The ``beta`` a call with these inputs fits with: the fixed one, or the GCV choice (NaN with
        no training expression, where ``beta`` has no effect)."""
        if self.beta != "gcv":
            return float(self.beta)
        return self.choose_beta(template, target_neutral, weights, examples).beta

    def _beta(self, rigging: GradientSpaceRigging, weights: np.ndarray) -> float:
        if self.beta != "gcv":
            return float(self.beta)
        return rigging.choose_beta(weights, *self.beta_range).beta

    def checked(
        self, template: object, target_neutral: object, weights: object, examples: object
    ) -> TransferInputs:
        """The arguments of a call, checked (`transfer._inputs.check_inputs`)."""
        return check_inputs(
            template, target_neutral, weights, examples, method=self.name, binary=self.binary_weights
        )
