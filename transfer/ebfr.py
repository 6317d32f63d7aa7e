"""Example-based facial rigging in gradient space, step A (Li et al. 2010, 3A; Carrigan et al. 2020, 5)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from transfer._base import Transfer, check_positive
from transfer._frames import (
    aligned_template,
    edge_vectors,
    shape_major,
    transferred_edges,
    triangle_chunks,
    vertex_major,
)
from transfer._inputs import TransferInputs
from transfer._reconstruct import FrameReconstruction


def regularisation_weights(
    template_deltas: np.ndarray,
    triangles: np.ndarray,
    *,
    kappa: float = 0.1,
    theta: float = 2.0,
    motion_scale: str = "peak",
) -> np.ndarray:
    """Per-triangle weights ``w_i = ((1 + |M_i^A|) / (kappa + |M_i^A|))^theta`` (Li et al. 2010, sec. 3A).

    Triangles that barely move in template shape i get the largest weight ``kappa^-theta``, so the
    target shape keeps the template's (lack of) motion there; strongly moving triangles may deviate.

    Parameters
    ----------
    template_deltas : (N, 3, K) array, vertex-major
    triangles : (T, 3) int array
    kappa, theta : float
        Li et al. use ``kappa = 0.1`` and ``theta = 2``.
    motion_scale : {"peak", "absolute"}
        How ``|M_i^A|``, the Frobenius norm of shape i's edge displacements on a triangle, is measured.
        ``"peak"`` divides it by its largest value over the triangles of shape i, so the most active
        triangles of every shape get ``|M_i^A| = 1`` whatever the rig's units and resolution
        (Carrigan et al. 2020, sec. 5.2 aim for scale-free parameters). ``"absolute"`` follows Li et
        al. literally in the rig's units.

    Returns
    -------
    (T, K) array of weights; for ``"peak"`` between ``(2 / (kappa + 1))^theta`` and ``kappa^-theta``.
    Empty shapes get ``kappa^-theta`` everywhere.
    """
    if motion_scale not in ("peak", "absolute"):
        raise ValueError(f"motion_scale must be 'peak' or 'absolute', got {motion_scale!r}")
    n_shapes = template_deltas.shape[-1]
    motion = np.empty((triangles.shape[0], n_shapes))
    for part in triangle_chunks(triangles.shape[0], 2 * n_shapes):
        motion[part] = np.sqrt(np.sum(edge_vectors(template_deltas, triangles[part]) ** 2, axis=(1, 2)))
    if motion_scale == "peak" and motion.size:
        peak = motion.max(axis=0)
        motion /= np.where(peak > 0, peak, 1.0)
    return ((1.0 + motion) / (kappa + motion)) ** theta


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
        Weights ``w_ti > 0`` (see `regularisation_weights`).
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
    expression has a zero column in W, hence a zero update: it keeps the prior exactly.
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


class GradientSpaceRigging:
    """Step A of example-based rigging prepared for one template, target neutral and set of examples.

    Everything that does not depend on the expression weights is computed once: the aligned template,
    the deformation-transfer prior, the regularisation weights, the training frames, the vertex
    solver and its constraints. `blendshapes` may then be called with any weights and ``beta``
    (`transfer.ebfr_full` calls it once per iteration).

    Parameters
    ----------
    inputs : TransferInputs
    kappa, theta, motion_scale, static_tolerance, align
        See `ExampleBasedRigging`.
    factor_budget : int
        Entries of sparse factorisations kept between `blendshapes` calls (see `FrameReconstruction`).

    Attributes
    ----------
    template_deltas : (N, 3, K) array
        The template's shapes, vertex-major, rotated to face like the target.
    prior : (T, 2, 3, K) array
        Deformation-transfer edges of the target shapes, ``M_i^{A*}``.
    regularisation : (T, K) array
        Weights ``w_i`` of ``E_reg``.
    observed : (T, 2, 3, J) array
        Edges of the training expressions minus the target neutral's.
    reconstruction : FrameReconstruction
    fixed : (K, N) bool array
        Vertices held in each shape.
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
        factor_budget: int = 0,
    ) -> None:
        template, target = inputs.template, inputs.target_neutral
        triangles = template.triangles
        neutral, self.template_deltas = aligned_template(
            template.neutral, vertex_major(template.deltas), target, align
        )
        self.prior = transferred_edges(neutral, self.template_deltas, target, triangles)
        self.regularisation = regularisation_weights(
            self.template_deltas, triangles, kappa=kappa, theta=theta, motion_scale=motion_scale
        )
        self.observed = edge_vectors(vertex_major(inputs.examples - target), triangles)
        self.reconstruction = FrameReconstruction(target, triangles, factor_budget)
        self.fixed = self.reconstruction.constraints(self.template_deltas, static_tolerance)

    def blendshapes(self, weights: np.ndarray, beta: float) -> np.ndarray:
        """Target deltas ``(K, N, 3)`` for expression ``weights (J, K)`` and balance ``beta``."""
        edges = fit_edge_frames(self.prior, self.regularisation, weights, self.observed, beta)
        return shape_major(self.reconstruction.solve(edges, self.fixed, self.template_deltas))


def check_regularisation(kappa: float, theta: float, motion_scale: str, static_tolerance: float) -> None:
    """Raise a `ValueError` naming the first bad parameter shared by the rigging methods."""
    if motion_scale not in ("peak", "absolute"):
        raise ValueError(f"motion_scale must be 'peak' or 'absolute', got {motion_scale!r}")
    check_positive(kappa, "kappa")
    check_positive(theta, "theta", allow_zero=True)
    check_positive(static_tolerance, "static_tolerance", allow_zero=True)


@dataclass(frozen=True)
class ExampleBasedRigging(Transfer):
    """Example-based facial rigging with known 0/1 weights (Li et al. 2010, step A; Carrigan et al. 2020).

    The target's blendshapes are fitted per triangle in gradient space to the training expressions,
    regularised towards deformation transfer of the template, then reconstructed as vertices with the
    template's static vertices held (Li et al. 2010, sec. 3A).

    Parameters
    ----------
    beta : float, default 0.1
        Weight of the regulariser ``E_reg`` against the fit ``E_fit`` (Li et al.: 0.1 balances accuracy
        and robustness; over-fitting below about 0.05). ``beta -> infinity`` is deformation transfer.
    kappa : float, default 0.1
        Regularisation-weight offset (Li et al. 2010, sec. 3A).
    theta : float, default 2.0
        Regularisation-weight exponent (Li et al. use 2).
    motion_scale : {"peak", "absolute"}, default "peak"
        Measure each template shape's triangle motion relative to its most active triangle (scale-free
        ``kappa``), or literally in the rig's units as Li et al. (see `regularisation_weights`).
    static_tolerance : float, default 1e-6
        Vertices moving at most this fraction of a template shape's largest displacement stay fixed.
    align : bool, default True
        Rotate the template to face like the target first (see `transfer.deformation`).

    Examples
    --------
    >>> import transfer
    >>> method = transfer.get("ebfr", beta=0.1)
    >>> deltas = method(template, target.neutral, weights, examples)  # doctest: +SKIP

    Notes
    -----
    The data term ``W^T W`` is the same for every triangle and has rank <= J, so the per-triangle systems
    are solved in one batched Woodbury step, O(T (K J^2 + J^3)) (see `fit_edge_frames`); the vertex
    solve costs one sparse factorisation per distinct set of static vertices. Shapes in no training
    expression come out as deformation transfer; with J = 0 the method is deformation transfer.
    """

    name: ClassVar[str] = "ebfr"
    binary_weights: ClassVar[bool] = True
    beta: float = 0.1
    kappa: float = 0.1
    theta: float = 2.0
    motion_scale: str = "peak"
    static_tolerance: float = 1e-6
    align: bool = True

    def __post_init__(self) -> None:
        check_positive(self.beta, "beta")
        check_regularisation(self.kappa, self.theta, self.motion_scale, self.static_tolerance)

    def transfer(self, inputs: TransferInputs) -> np.ndarray:
        """Step A with the given weights."""
        rigging = GradientSpaceRigging(
            inputs,
            kappa=self.kappa,
            theta=self.theta,
            motion_scale=self.motion_scale,
            static_tolerance=self.static_tolerance,
            align=self.align,
        )
        return rigging.blendshapes(inputs.weights, self.beta)
