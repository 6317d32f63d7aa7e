"""Quasi-static simulations of AnaConDaR by projective dynamics (Wagner et al. 2024, eqs. 11-14, 18, A.1-A.6).

Projective dynamics (Bouaziz et al. 2014) minimises a sum of energies ``w_c ||A_c x - p_c||^2`` where each
``p_c`` is the projection of ``A_c x`` onto the constraint's set: a local step projects every constraint
(batched numpy: one SVD per tetrahedron), a global step solves ``(sum w_c A_c^T A_c) x = sum w_c A_c^T
p_c``, whose matrix does not change and is factorised once per head (SciPy's sparse LU).

- **Inverse simulation** (eq. 14): soft tissue has a strain term (projection onto rotations, eq. 11) and
  a volume term (onto ``det = 1``, eq. 11), muscle the volume term only (eq. 12), and the skin is drawn
  to the target by ``w_tar`` (eq. 13). Skull vertices are held where the bones' rigid motions put them.
- **Forward simulation** (eq. 18): each tetrahedron is drawn to a given deformation gradient (eqs.
  A.5-A.6), the eye triangles to given areas (A.2-A.3) and the lip contour to given positions (A.4),
  the skull again held by its bones.

Each term is measured as the paper's (a sum over tetrahedra of Frobenius norms, a sum over vertices of
squared distances) with two normalisations that make Table 3's weights mean the same on any rig: a
tetrahedron counts in proportion to its volume over the mean volume, and distances are measured in
millimetres of a face scaled to a 30 cm skin diagonal (the paper reports millimetres), each rig vertex
weighing its share of the skin's area over the mean area of a coarse vertex (so the target term counts
coarse vertices, as the paper's counts the vertices of its tetrahedral skin).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp

from transfer._features import Features
from transfer._head import Head, HeadTemplate

#: Shapes simulated at once (bounds the ``(B * T, 3, 3)`` local-step arrays).
BATCH = 16
#: Regularisation of the global matrices towards the rest pose, relative to their mean diagonal: it only
#: keeps a vertex that no term reaches at rest.
_RIDGE = 1e-9
#: Bounding-box diagonal of an adult face's skin in millimetres: distances are measured in millimetres of
#: a face of this size, the unit of the paper's weights.
FACE_DIAGONAL = 300.0
#: The four corners of a tetrahedron to its three edges from the first.
_EDGES = np.array([[-1.0, 1.0, 0.0, 0.0], [-1.0, 0.0, 1.0, 0.0], [-1.0, 0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class Weights:
    """The weights of Table 3 (Wagner et al. 2024).

    Attributes
    ----------
    strain, muscle, target : float
        ``w_S``, ``w_M``, ``w_tar`` of the inverse simulation (eq. 14).
    soft_gradient, muscle_gradient, characteristics : float
        ``w_grad_S``, ``w_grad_M``, ``w_F`` of the forward simulation (eq. 18); ``characteristics = 0``
        leaves the facial characteristics out.
    """

    strain: float = 1.0
    muscle: float = 1.0
    target: float = 100.0
    soft_gradient: float = 1.0
    muscle_gradient: float = 1.0
    characteristics: float = 10.0


@dataclass(frozen=True)
class Bones:
    """Rigid motions of the cranium and the jaw for B shapes: ``x -> R (x - c) + c + t`` (``nabla B``).

    Attributes
    ----------
    rotations : (B, 2, 3, 3) array
        Cranium (0) and jaw (1).
    translations : (B, 2, 3) array
    """

    rotations: np.ndarray
    translations: np.ndarray


def _operator(
    rows: np.ndarray, columns: np.ndarray, values: np.ndarray, shape: tuple[int, int]
) -> sp.csr_matrix:
    return sp.csr_matrix((values.ravel(), (rows.ravel(), columns.ravel())), shape=shape)


class Simulator:
    """Inverse and forward simulations on one fitted head, each global matrix factorised on first use.

    Parameters
    ----------
    template : HeadTemplate
    head : Head
    features : Features
    weights : Weights
    iterations : int
        Local-global iterations of the inverse simulation (and of the forward one with eye areas).

    Notes
    -----
    Building costs O(T) for T tetrahedra; each factorisation one sparse LU of the free volume vertices.
    A simulation of B shapes costs ``iterations`` batched SVDs of ``B T`` 3x3 matrices and triangular
    solves with ``3 B`` right-hand sides.
    """

    def __init__(
        self, template: HeadTemplate, head: Head, features: Features, weights: Weights, iterations: int
    ) -> None:
        self.template, self.head, self.weights, self.iterations = template, head, weights, iterations
        rest = head.rest
        n_volume = rest.shape[0]
        tets = template.tets[template.kept]
        soft = template.soft[template.kept]
        corners = rest[tets]
        shape_matrix = np.swapaxes(corners[:, 1:] - corners[:, :1], 1, 2)  # columns are edges
        volume = np.abs(np.linalg.det(shape_matrix)) / 6.0
        relative = volume / volume.mean()
        local = np.swapaxes(np.linalg.inv(shape_matrix), 1, 2) @ _EDGES  # F^T = local @ corners
        n_tets = len(tets)
        #: (3T, V): rows 3t..3t+2 give the transposed deformation gradient of tetrahedron t.
        self.gradient = _operator(
            np.repeat(np.arange(3 * n_tets), 4), np.repeat(tets, 3, axis=0), local, (3 * n_tets, n_volume)
        )
        self.soft = soft
        self.inverse_weight = relative * np.where(soft, weights.strain, weights.muscle)
        self.forward_weight = relative * np.where(soft, weights.soft_gradient, weights.muscle_gradient)
        self.fixed = template.skull
        self.free = np.setdiff1d(np.arange(n_volume), self.fixed)
        #: The length unit of the squared distances: a millimetre of a face whose skin is `FACE_DIAGONAL` mm.
        self.unit = head.size / FACE_DIAGONAL
        areas = _vertex_areas(head.neutral, template.triangles, head.neutral.shape[0])
        coarse_area = areas.sum() / max(template.n_coarse, 1)
        #: Weight of each rig vertex in the target term: its area over a coarse vertex's.
        self.area_share = areas / coarse_area
        self.embedding = head.embedding
        self._target = (
            self.embedding.T @ sp.diags(weights.target * self.area_share / self.unit**2) @ self.embedding
        )
        self._characteristics(features, coarse_area)
        self._factors: dict[str, Any] = {}

    def _characteristics(self, features: Features, coarse_area: float) -> None:
        """Operators of the lip contour and the eye triangles (eqs. A.2-A.4) on the volume vertices."""
        rest_surface = self.head.neutral
        weight = self.weights.characteristics
        contour = features.lip_contour[self.template.embed_tet[features.lip_contour] >= 0]
        self.contour = contour
        self.contour_weight = weight * self.area_share[contour] / self.unit**2
        rows = self.embedding[contour]
        self._contour = rows.T @ sp.diags(self.contour_weight) @ rows
        self.contour_rows = rows
        triangles = features.area_triangles
        triangles = triangles[(self.template.embed_tet[triangles] >= 0).all(axis=1)]
        corners = rest_surface[triangles]
        edges = np.stack((corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=2)  # (F, 3, 2)
        basis, frame = np.linalg.qr(edges)
        area = 0.5 * np.abs(np.linalg.det(frame)) if len(triangles) else np.zeros(0)
        valid = area > 1e-12 * self.unit**2
        self.area_valid = valid
        triangles, frame, area = triangles[valid], frame[valid], area[valid]
        self.area_weight = weight * area / coarse_area
        inverse = np.swapaxes(np.linalg.inv(frame), 1, 2) if len(triangles) else np.zeros((0, 2, 2))
        # F_f^T = inverse @ [p_j - p_i; p_k - p_i]: two rows per triangle over the rig's vertices.
        coefficients = np.stack((-inverse.sum(axis=2), inverse[:, :, 0], inverse[:, :, 1]), axis=2)
        n_vertices = self.embedding.shape[0]
        surface_operator = _operator(
            np.repeat(np.arange(2 * len(triangles)), 3),
            np.repeat(triangles, 2, axis=0),
            coefficients,
            (2 * len(triangles), n_vertices),
        )
        self.area_operator = (surface_operator @ self.embedding).tocsr()
        self._areas = self.area_operator.T @ sp.diags(np.repeat(self.area_weight, 2)) @ self.area_operator

    def factor(self, kind: str) -> Any:
        """The LU factor of the free block of the ``"inverse"`` or ``"forward"`` global matrix."""
        found = self._factors.get(kind)
        if found is None:
            from scipy.sparse.linalg import splu

            if kind == "inverse":
                weight = np.where(self.soft, 2.0, 1.0) * self.inverse_weight
                matrix = self.gradient.T @ sp.diags(np.repeat(weight, 3)) @ self.gradient + self._target
            else:
                matrix = self.gradient.T @ sp.diags(np.repeat(self.forward_weight, 3)) @ self.gradient
                matrix = matrix + self._contour + self._areas
            ridge = _RIDGE * float(matrix.diagonal().mean())
            matrix = (matrix + ridge * sp.identity(matrix.shape[0])).tocsr()
            free = matrix[self.free][:, self.free].tocsc()
            coupling = matrix[self.free][:, self.fixed].tocsr()
            lu = splu(
                free, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True}
            )
            found = self._factors[kind] = (lu, coupling, ridge)
        return found

    def skull(self, bones: Bones, translation_scale: float = 1.0) -> np.ndarray:
        """``(B, S, 3)`` skull positions: each bone's rigid motion about its centre on this head,
        translations scaled by ``translation_scale`` (``BB(T) / BB(S)`` in the forward simulation)."""
        rest = self.head.rest[self.fixed]
        jaw = self.template.jaw
        centre = np.where(jaw[:, None], self.head.jaw_centre, self.head.cranium_centre)
        bone = jaw.astype(int)
        rotated = np.einsum("bsij,bsj->bsi", bones.rotations[:, bone], (rest - centre)[None])
        return rotated + centre + translation_scale * bones.translations[:, bone]

    def _solve(self, kind: str, rhs: np.ndarray, skull: np.ndarray) -> np.ndarray:
        """Positions ``(B, V, 3)`` from the right-hand side ``(V, B, 3)`` with the skull held."""
        lu, coupling, ridge = self.factor(kind)
        n_shapes = rhs.shape[1]
        fixed = np.ascontiguousarray(skull.transpose(1, 0, 2)).reshape(len(self.fixed), -1)
        rest = np.repeat(self.head.rest[self.free][:, None], n_shapes, axis=1).reshape(len(self.free), -1)
        right = rhs[self.free].reshape(len(self.free), -1) + ridge * rest - coupling @ fixed
        result = np.empty((rhs.shape[0], n_shapes, 3))
        result[self.free] = lu.solve(right).reshape(len(self.free), n_shapes, 3)
        result[self.fixed] = skull.transpose(1, 0, 2)
        return result.transpose(1, 0, 2)

    def _gradients(self, positions: np.ndarray) -> np.ndarray:
        """``(B, T, 3, 3)`` transposed deformation gradients of ``(B, V, 3)`` positions."""
        n_shapes = positions.shape[0]
        flat = np.ascontiguousarray(positions.transpose(1, 0, 2)).reshape(positions.shape[1], -1)
        return (self.gradient @ flat).reshape(-1, 3, n_shapes, 3).transpose(2, 0, 1, 3)

    def _spread(self, weight: np.ndarray, values: np.ndarray) -> np.ndarray:
        """``G^T diag(weight) values`` for ``(B, T, 3, 3)`` values, as a ``(V, B, 3)`` array."""
        n_shapes = values.shape[0]
        weighted = values * weight[None, :, None, None]
        flat = np.ascontiguousarray(weighted.transpose(1, 2, 0, 3)).reshape(-1, 3 * n_shapes)
        return (self.gradient.T @ flat).reshape(-1, n_shapes, 3)

    def inverse(self, displacements: np.ndarray, bones: Bones) -> np.ndarray:
        """``invSim`` (eqs. 8, 11-14): volume positions whose skin follows the rig's ``(B, N, 3)``
        displacements, with the bones' motions, by `iterations` local-global steps from the rest pose.

        Returns
        -------
        (B, V, 3) array of volume vertex positions.
        """
        n_shapes = displacements.shape[0]
        skull = self.skull(bones)
        goal = self.head.neutral + displacements  # rig positions (B, N, 3)
        weight = self.weights.target * self.area_share / self.unit**2
        pull = (
            self.embedding.T
            @ (weight[:, None] * np.ascontiguousarray(goal.transpose(1, 0, 2)).reshape(goal.shape[1], -1))
        ).reshape(-1, n_shapes, 3)
        positions = np.repeat(self.head.rest[None], n_shapes, axis=0)
        positions[:, self.fixed] = skull
        for _ in range(self.iterations):
            gradients = self._gradients(positions)
            rotation, volume = _project(gradients)
            soft = np.where(self.soft[None, :, None, None], rotation + volume, volume)
            positions = self._solve("inverse", pull + self._spread(self.inverse_weight, soft), skull)
        return positions

    def forward(
        self,
        gradients: np.ndarray,
        skull: np.ndarray,
        contour: np.ndarray | None,
        ratios: np.ndarray | None,
        start: np.ndarray,
    ) -> np.ndarray:
        """``fwdSim`` (eqs. 10, 18): volume positions that take on given deformation gradients.

        Parameters
        ----------
        gradients : (B, T, 3, 3) array
            Transposed deformation gradients per kept tetrahedron (``nabla S``, ``nabla M``).
        skull : (B, S, 3) array
            Skull positions (see `skull`).
        contour : (B, L, 3) array or None
            Lip contour positions ``F_lc`` (eq. 16) of the contour vertices with an embedding.
        ratios : (B, F) array or None
            Area ratios of the eye triangles (eq. 15).
        start : (B, V, 3) array
            The first iterate: the area projections are taken there.

        Returns
        -------
        (B, V, 3) array.
        """
        n_shapes = gradients.shape[0]
        rhs = self._spread(self.forward_weight, gradients)
        if contour is not None and len(self.contour):
            flat = np.ascontiguousarray(contour.transpose(1, 0, 2)).reshape(len(self.contour), -1)
            rhs = rhs + (self.contour_rows.T @ (self.contour_weight[:, None] * flat)).reshape(-1, n_shapes, 3)
        n_area = len(self.area_weight)
        if ratios is None or n_area == 0 or self.weights.characteristics == 0:
            return self._solve("forward", rhs, skull)
        ratios = ratios[:, self.area_valid]
        positions = start
        for _ in range(self.iterations):
            flat = np.ascontiguousarray(positions.transpose(1, 0, 2)).reshape(positions.shape[1], -1)
            frames = (self.area_operator @ flat).reshape(n_area, 2, n_shapes, 3).transpose(2, 0, 1, 3)
            left, singular, right = np.linalg.svd(frames, full_matrices=False)
            product = singular[..., 0] * singular[..., 1]
            scale = np.sqrt(np.where(product > 0, ratios / np.where(product > 0, product, 1.0), 0.0))
            wanted = np.where(product[..., None] > 0, singular * scale[..., None], np.sqrt(ratios)[..., None])
            projected = (left * wanted[..., None, :]) @ right
            weighted = projected * self.area_weight[None, :, None, None]
            spread = self.area_operator.T @ np.ascontiguousarray(weighted.transpose(1, 2, 0, 3)).reshape(
                2 * n_area, -1
            )
            positions = self._solve("forward", rhs + spread.reshape(-1, n_shapes, 3), skull)
        return positions

    def linear_fit(self, displacements: np.ndarray) -> np.ndarray:
        """The part of ``(B, N, 3)`` rig displacements that the volume takes on by the inverse simulation's
        quadratic terms alone (rotations and volumes at rest, skull at rest), seen on the rig's vertices.

        This splits a displacement field into what the coarse volume can express and what it cannot.
        """
        n_shapes = displacements.shape[0]
        weight = self.weights.target * self.area_share / self.unit**2
        flat = np.ascontiguousarray(displacements.transpose(1, 0, 2)).reshape(displacements.shape[1], -1)
        rhs = (self.embedding.T @ (weight[:, None] * flat)).reshape(-1, n_shapes, 3)
        lu, _, _ = self.factor("inverse")
        solved = np.zeros((rhs.shape[0], n_shapes * 3))
        solved[self.free] = lu.solve(rhs[self.free].reshape(len(self.free), -1))
        return (self.embedding @ solved).reshape(-1, n_shapes, 3).transpose(1, 0, 2)

    def surface(self, positions: np.ndarray) -> np.ndarray:
        """``(B, N, 3)`` displacements of the embedded rig vertices (zero on the others)."""
        moved = positions - self.head.rest[None]
        flat = np.ascontiguousarray(moved.transpose(1, 0, 2)).reshape(moved.shape[1], -1)
        return (self.embedding @ flat).reshape(-1, moved.shape[0], 3).transpose(1, 0, 2)


def _project(gradients: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nearest rotations and unit-volume versions of ``(..., 3, 3)`` (transposed) deformation gradients.

    The rotation (the strain projection of Bouaziz et al. 2014, eq. 11) is the polar factor, found by
    `_POLAR_STEPS` steps of Higham's scaled Newton iteration on all matrices at once (about five times
    faster than a batched SVD, and converged to rounding error for elements that are not inverted);
    inverted elements take the SVD route with the sign of the last singular vector flipped. The volume
    projection (eqs. 11-12) scales a matrix uniformly to determinant 1 (an inverted element goes to its
    rotation), which keeps its shape and is exact on the constraint set.
    """
    determinant = np.linalg.det(gradients)
    rotation = _polar(gradients)
    inverted = determinant <= 0
    if inverted.any():
        left, _, right = np.linalg.svd(gradients[inverted])
        sign = np.sign(np.linalg.det(left @ right))
        left[..., :, 2] *= np.where(sign == 0, 1.0, sign)[..., None]
        rotation[inverted] = left @ right
    root = np.cbrt(np.where(inverted, 1.0, determinant))
    volume = np.where(inverted[..., None, None], rotation, gradients / root[..., None, None])
    return rotation, volume


#: Newton steps of the polar decomposition (from a deformation gradient of moderate strain, five steps
#: reach rounding error).
_POLAR_STEPS = 5


def _polar(matrices: np.ndarray) -> np.ndarray:
    """Orthogonal polar factors of ``(..., 3, 3)`` matrices: ``X <- (g X + X^-T / g) / 2`` with
    ``g = |det X|^(-1/3)`` (Higham 1986), on the nine entries as separate arrays."""
    m = np.moveaxis(matrices.reshape(*matrices.shape[:-2], 9), -1, 0)
    for _ in range(_POLAR_STEPS):
        a, b, c, d, e, f, g, h, i = m
        cofactors = (
            e * i - f * h, f * g - d * i, d * h - e * g,
            c * h - b * i, a * i - c * g, b * g - a * h,
            b * f - c * e, c * d - a * f, a * e - b * d,
        )  # fmt: skip
        determinant = a * cofactors[0] + b * cofactors[1] + c * cofactors[2]
        determinant = np.where(determinant == 0, 1.0, determinant)
        root = np.cbrt(np.abs(determinant))
        own, other = 0.5 / root, 0.5 * root / determinant
        m = np.stack([value * own + cofactor * other for value, cofactor in zip(m, cofactors, strict=True)])
    return np.moveaxis(m, 0, -1).reshape(matrices.shape)


def _vertex_areas(positions: np.ndarray, triangles: np.ndarray, n_vertices: int) -> np.ndarray:
    """A third of the area of every triangle at each of its corners."""
    corners = positions[triangles]
    area = 0.5 * np.linalg.norm(
        np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1
    )
    return np.bincount(triangles.ravel(), np.repeat(area / 3.0, 3), minlength=n_vertices)
