"""Patchwise linear blendshapes plus deformation transfer of the residual (Wagner et al. 2024, sec. 3.2)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from transfer._base import Transfer, check_positive
from transfer._frames import vertex_major
from transfer._inputs import TransferInputs
from transfer.deformation import deformation_transfer

if TYPE_CHECKING:
    import scipy.sparse as sp

#: Shapes handled at once; bounds the ``(N, J, chunk)`` coefficient arrays.
_SHAPE_CHUNK = 32


def patch_blendshapes(
    template_offsets: np.ndarray,
    target_offsets: np.ndarray,
    template_deltas: np.ndarray,
    blend: sp.csr_matrix,
    lambda_reg: float,
    scale: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Patchwise linear blendshapes of the template and the target (Wagner et al. 2024, eqs. 1-3).

    For patch p and template shape i the ridge weights ``w_pi`` minimise
    ``sum_v phi_p(v) |sum_j w_j e_j(v) - a_i(v)|^2 / scale^2 + lambda_reg |w|^2`` (eq. 2), where ``e_j``
    are the template expressions' displacements and ``phi_p`` the patch's blend weight. Each vertex
    blends the patch weights, ``c_i(v) = sum_p phi_p(v) w_pi``, and applies them to the template
    expressions (the source approximation ``S_i^P``, eq. 1) and to the target's (``T_i^P``, eq. 3).

    Parameters
    ----------
    template_offsets : (N, J, 3) array
        Displacements of the template expressions from the template neutral, vertex-major.
    target_offsets : (N, J, 3) array
        Displacements of the target's training expressions from the target neutral.
    template_deltas : (N, 3, K) array, vertex-major
    blend : (N, P) sparse matrix
        Patch weights of every vertex (see `blend_weights`).
    lambda_reg : float
        Ridge weight (Wagner et al.: 0.01).
    scale : float
        Length unit of the data term (the template's bounding-box diagonal), which makes
        ``lambda_reg`` independent of the rig's units.

    Returns
    -------
    source : (K, N, 3) array
        ``S_i^P - S``, the template shapes as the expressions explain them.
    target : (K, N, 3) array
        ``T_i^P - T``, the same weights applied to the target's expressions.

    Notes
    -----
    O(N J (J + K) + P J^3 + P J^2 K); all patches are solved in one batched call per chunk of shapes.
    """
    n_vertices, n_expressions, _ = template_offsets.shape
    n_shapes = template_deltas.shape[-1]
    transposed = np.ascontiguousarray(template_offsets.transpose(0, 2, 1))  # (N, 3, J)
    gram = blend.T @ (template_offsets @ transposed).reshape(n_vertices, -1) / scale**2
    system = gram.reshape(-1, n_expressions, n_expressions) + lambda_reg * np.eye(n_expressions)
    n_patches = system.shape[0]
    source = np.empty((n_shapes, n_vertices, 3))
    target = np.empty((n_shapes, n_vertices, 3))
    for start in range(0, n_shapes, _SHAPE_CHUNK):
        part = slice(start, start + _SHAPE_CHUNK)
        shapes = template_deltas[:, :, part]
        count = shapes.shape[-1]
        cross = blend.T @ (template_offsets @ shapes).reshape(n_vertices, -1) / scale**2
        weights = np.linalg.solve(system, cross.reshape(n_patches, n_expressions, count))
        per_vertex = (blend @ weights.reshape(n_patches, -1)).reshape(n_vertices, n_expressions, count)
        per_vertex = per_vertex.transpose(0, 2, 1)  # (N, k, J)
        source[part] = (per_vertex @ template_offsets).transpose(1, 0, 2)
        target[part] = (per_vertex @ target_offsets).transpose(1, 0, 2)
    return source, target


@dataclass(frozen=True)
class PatchwiseBlendshapes(Transfer):
    """Patchwise linear blendshapes with the residual transferred (Wagner et al. 2024, sec. 3.2).

    The mesh is split into patches. On each patch every template shape is approximated by a ridge
    combination of the template's training expressions (eqs. 1-2); the same coefficients applied to
    the target's training expressions give the data-driven part (eq. 3). What the expressions cannot
    explain, the missing blendshape ``A_i - S_i^P`` (eq. 4), is carried over by deformation transfer
    (eq. 5, with Sumner & Popovic's transfer in place of the anatomical one) and added (eq. 6 without the
    physics step).

    Parameters
    ----------
    n_patches : int, default 80
        Number of patches (Wagner et al.'s layout has 80).
    blend_rings : int, default 3
        Patches overlap and their coefficients are blended over this many rings of neighbours, so the
        result has no seams; 0 gives hard patches as in the paper, whose borders then show.
    lambda_reg : float, default 0.01
        Ridge weight of eq. 2, with positions measured in template bounding-box diagonals.
    seed : int, default 0
        Seed of the patch layout.
    static_tolerance : float, default 1e-6
        Static threshold of the residual's deformation transfer (see `transfer.deformation`).
    align : bool, default True
        Remove a global rotation between template and target in the residual transfer.

    Examples
    --------
    >>> import transfer
    >>> deltas = transfer.get("plbs")(template, target.neutral, weights, examples)  # doctest: +SKIP

    Notes
    -----
    With no training expressions this is deformation transfer. Any real weights are accepted.
    """

    name: ClassVar[str] = "plbs"
    n_patches: int = 80
    blend_rings: int = 3
    lambda_reg: float = 0.01
    seed: int = 0
    static_tolerance: float = 1e-6
    align: bool = True

    def __post_init__(self) -> None:
        if int(self.n_patches) != self.n_patches or self.n_patches < 1:
            raise ValueError(f"n_patches must be a positive integer, got {self.n_patches!r}")
        if int(self.blend_rings) != self.blend_rings or self.blend_rings < 0:
            raise ValueError(f"blend_rings must be a non-negative integer, got {self.blend_rings!r}")
        check_positive(self.lambda_reg, "lambda_reg")
        check_positive(self.static_tolerance, "static_tolerance", allow_zero=True)

    def transfer(self, inputs: TransferInputs) -> np.ndarray:
        """Data-driven patch blend plus transferred residual."""
        from transfer._patches import blend_weights, partition

        template = inputs.template
        target = inputs.target_neutral
        residual = template.deltas
        data_driven = 0.0
        if inputs.weights.shape[0]:
            labels = partition(template.neutral, template.triangles, self.n_patches, seed=self.seed)
            blend = blend_weights(labels, template.triangles, self.blend_rings)
            template_offsets = np.tensordot(inputs.weights, template.deltas, axes=1)
            source, data_driven = patch_blendshapes(
                np.ascontiguousarray(template_offsets.transpose(1, 0, 2)),
                np.ascontiguousarray((inputs.examples - target).transpose(1, 0, 2)),
                vertex_major(template.deltas),
                blend,
                self.lambda_reg,
                template.diagonal() or 1.0,
            )
            residual = template.deltas - source
        return data_driven + deformation_transfer(
            template.neutral,
            residual,
            target,
            template.triangles,
            static_tolerance=self.static_tolerance,
            align=self.align,
        )
