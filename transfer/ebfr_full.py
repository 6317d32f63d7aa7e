"""Example-based facial rigging with weight re-estimation, steps A and B alternated (Li et al. 2010)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from transfer._base import Transfer, check_positive
from transfer._inputs import TransferInputs, check_inputs
from transfer.ebfr import RiggingSettings


def schedule(start: float, end: float, steps: int) -> np.ndarray:
    """``steps`` values decreasing geometrically from ``start`` to ``end`` (Li et al. 2010, sec. 4)."""
    return np.geomspace(start, end, steps) if steps > 1 else np.array([end], dtype=float)


def box_quadratic(
    hessian: np.ndarray,
    linear: np.ndarray,
    start: np.ndarray,
    *,
    tolerance: float = 1e-10,
    max_iterations: int = 20000,
) -> np.ndarray:
    """Minimise ``x^T H x / 2 - b^T x`` over the unit box ``[0, 1]^K``, for several ``b`` at once.

    Accelerated projected gradient (FISTA) with the gradient restart of O'Donoghue & Candes (2015), on
    the Jacobi-scaled variables ``z = sqrt(diag H) x`` (the box stays a box) and with step
    ``1 / lambda_max``; all columns iterate together since they share ``H``.

    Parameters
    ----------
    hessian : (K, K) symmetric positive definite array
    linear : (K, J) array
        One right-hand side ``b`` per column.
    start : (K, J) array
        Initial guess (projected onto the box).
    tolerance : float
        Stop when no weight moves more than this in a projected-gradient step.
    max_iterations : int

    Returns
    -------
    (K, J) array in ``[0, 1]``.

    Notes
    -----
    Each iteration is one ``(K, K) @ (K, J)`` product; the iteration count grows with the square root
    of the condition number of the scaled ``H``.
    """
    unit = 1.0 / np.sqrt(np.diag(hessian))
    scaled = hessian * unit[:, None] * unit[None, :]
    scaled_linear = linear * unit[:, None]
    upper = (1.0 / unit)[:, None]
    step = 1.0 / np.linalg.eigvalsh(scaled)[-1]
    current = np.clip(start / unit[:, None], 0.0, upper)
    ahead = current.copy()
    momentum = np.ones(current.shape[1])
    for _ in range(max_iterations):
        following = np.clip(ahead - step * (scaled @ ahead - scaled_linear), 0.0, upper)
        if np.abs((following - ahead) * unit[:, None]).max(initial=0.0) <= tolerance:
            break
        restart = np.einsum("kj,kj->j", ahead - following, following - current) > 0
        momentum = np.where(restart, 1.0, momentum)
        accelerated = (1.0 + np.sqrt(1.0 + 4.0 * momentum**2)) / 2.0
        ahead = following + ((momentum - 1.0) / accelerated) * (following - current)
        current, momentum = following, accelerated
    return np.clip(following * unit[:, None], 0.0, 1.0)


def refit_weights(
    deltas: np.ndarray,
    offsets: np.ndarray,
    initial: np.ndarray,
    gamma: float,
    scale: float,
) -> np.ndarray:
    """Step B: expression weights in [0, 1] by least squares with the initial weights as soft constraints.

    For each expression j minimises
    ``sum_n |s_j^n - b_0^n - sum_i a_ij b_i^n|^2 + gamma sum_i (a_ij - a*_ij)^2``
    subject to ``0 <= a_ij <= 1`` (Li et al. 2010, ``E_B``, sec. 3B): the box-constrained quadratic
    with Hessian ``B^T B + gamma I``, shared by all expressions (see `box_quadratic`).

    Parameters
    ----------
    deltas : (K, N, 3) array
        Current target blendshapes.
    offsets : (J, N, 3) array
        Training expressions minus the target neutral.
    initial : (J, K) array
        The given weights ``a*`` in [0, 1]; also the starting point.
    gamma : float
        Weight of the soft constraints.
    scale : float
        Factor applied to positions before the data term is evaluated (see `ExampleBasedRiggingFull`).

    Returns
    -------
    (J, K) array of weights in [0, 1].

    Notes
    -----
    O(K^2 N) for ``B^T B`` plus the iterations of `box_quadratic`. Li et al.'s mutual-exclusion
    penalties between shapes are not modelled (no such pairs are given).
    """
    n_shapes = deltas.shape[0]
    basis = deltas.reshape(n_shapes, -1) * scale
    hessian = basis @ basis.T + gamma * np.eye(n_shapes)
    linear = basis @ (offsets.reshape(offsets.shape[0], -1) * scale).T + gamma * initial.T  # (K, J)
    return box_quadratic(hessian, linear, initial.T).T


@dataclass(frozen=True)
class ExampleBasedRiggingFull(RiggingSettings, Transfer):
    """Example-based facial rigging alternating blendshape and weight optimisation (Li et al. 2010).

    Each iteration runs step A (`transfer.ebfr`: blendshapes in gradient space for fixed weights) and
    then step B (weights re-estimated by bounded least squares, the given weights as soft constraints).
    ``beta`` and ``gamma`` decrease geometrically over the iterations; the last iteration ends with
    step A, so the returned blendshapes match the final weights.

    Parameters
    ----------
    iterations : int, default 10
        Number of step-A solves (Li et al. use 10).
    beta_schedule : (float, float), default (0.5, 0.1)
        First and last ``beta`` (Li et al. 2010, sec. 4).
    gamma_schedule : (float, float), default (1000.0, 100.0)
        First and last ``gamma`` (Li et al. 2010, sec. 4).
    head_size : float, default 250.0
        Li et al.'s ``gamma`` values weigh squared distances of a human head in millimetres; step B
        measures positions in units that make the template's bounding-box diagonal this long, so the
        schedule means the same for any rig units.
    kappa, theta, motion_scale, static_tolerance, align
        The regularisation (`transfer.ebfr.RiggingSettings`).

    Examples
    --------
    >>> import transfer
    >>> method = transfer.get("ebfr-full", iterations=5)
    >>> deltas, weights = method.fit(template, target.neutral, weights, examples)  # doctest: +SKIP

    Notes
    -----
    Weights need not be 0/1 but must lie in [0, 1]. Each iteration costs one step A (see
    `transfer.ebfr`; factorisations are reused across iterations) and one step B.
    """

    name: ClassVar[str] = "ebfr-full"
    iterations: int = 10
    beta_schedule: tuple[float, float] = (0.5, 0.1)
    gamma_schedule: tuple[float, float] = (1000.0, 100.0)
    head_size: float = 250.0

    def __post_init__(self) -> None:
        super().__post_init__()
        if int(self.iterations) != self.iterations or self.iterations < 1:
            raise ValueError(f"iterations must be a positive integer, got {self.iterations!r}")
        for argument in ("beta_schedule", "gamma_schedule"):
            values = getattr(self, argument)
            if not isinstance(values, tuple | list) or len(values) != 2:
                raise ValueError(f"{argument} must be (first, last), got {values!r}")
            for value in values:
                check_positive(value, argument)
        check_positive(self.head_size, "head_size")

    def fit(
        self, template: object, target_neutral: object, weights: object = None, examples: object = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Blendshapes and re-estimated weights; arguments as for calling the method.

        Returns
        -------
        deltas : (K, N, 3) array
        weights : (J, K) array in [0, 1]
        """
        return self._fit(check_inputs(template, target_neutral, weights, examples, method=self.name))

    def transfer(self, inputs: TransferInputs) -> np.ndarray:
        """Blendshapes after the alternating optimisation."""
        return self._fit(inputs)[0]

    def _fit(self, inputs: TransferInputs) -> tuple[np.ndarray, np.ndarray]:
        initial = inputs.weights
        if initial.size and (initial.min() < 0 or initial.max() > 1):
            j, k = (int(i) for i in np.argwhere((initial < 0) | (initial > 1))[0])
            raise ValueError(
                f"weights must lie in [0, 1] for {self.name!r} (bounded weights); "
                f"weights[{j}, {k}] = {float(initial[j, k])!r}"
            )
        rigging = self.rigging(inputs)
        betas = schedule(*self.beta_schedule, self.iterations)
        gammas = schedule(*self.gamma_schedule, self.iterations)
        scale = self.head_size / (inputs.template.diagonal() or 1.0)
        offsets = inputs.examples - inputs.target_neutral
        weights = initial
        for iteration, (beta, gamma) in enumerate(zip(betas, gammas, strict=True)):
            deltas = rigging.blendshapes(weights, beta)
            if iteration + 1 < self.iterations and initial.shape[0]:
                weights = refit_weights(deltas, offsets, initial, gamma, scale)
        return deltas, weights
