"""Triangle frames and deformation gradients (Sumner & Popovic 2004; Li et al. 2010, sec. 3A).

Shapes are ``(K, N, 3)`` arrays (a shape's vertices are contiguous, so gathering the corners of the
triangles one shape moves is cheap), and edge data is *triangle-major*, ``(F, 2, 3, S)`` (triangle, edge
``v2 - v1`` or ``v3 - v1``, coordinate, shape): every per-triangle operation then runs over contiguous
blocks, batched over shapes, and the vertex solve reads the edges as a ``(2F, 3S)`` matrix without
copying.
"""

from __future__ import annotations

import numpy as np

#: Triangles whose doubled area is below this fraction of the squared mesh extent count as degenerate.
DEGENERATE_TOLERANCE = 1e-14

#: Target number of float64 entries in one chunk's ``(triangles, 3, K)`` temporaries.
CHUNK_ENTRIES = 1 << 20


def vertex_major(deltas: np.ndarray) -> np.ndarray:
    """``(K, N, 3)`` shapes as a contiguous ``(N, 3, K)`` array."""
    return np.ascontiguousarray(np.moveaxis(deltas, 0, -1))


def triangle_chunks(n_triangles: int, n_columns: int) -> list[slice]:
    """Slices of triangles small enough that a ``(chunk, 3, n_columns)`` array stays bounded."""
    size = max(1, CHUNK_ENTRIES // (3 * max(n_columns, 1)))
    return [slice(start, start + size) for start in range(0, n_triangles, size)]


def edge_vectors(values: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Edges ``v2 - v1`` and ``v3 - v1`` of every triangle.

    Parameters
    ----------
    values : (N, 3, ...) array
        Positions or displacements (the map is linear), optionally with trailing shape axes.
    triangles : (T, 3) int array

    Returns
    -------
    (T, 2, 3, ...) array.
    """
    first = values[triangles[:, 0]]
    return np.stack((values[triangles[:, 1]] - first, values[triangles[:, 2]] - first), axis=1)


def scaled_normals(edges: np.ndarray) -> np.ndarray:
    """``n / sqrt(|n|)`` with ``n = e1 x e2``, from ``(T, 2, 3, ...)`` edges to ``(T, 3, ...)``.

    The square-root scaling gives the normal the units of an edge, as the fourth vertex of Sumner &
    Popovic (2004, sec. 3) does.
    """
    a, b = edges[:, 0], edges[:, 1]
    normal = np.stack(
        (
            a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1],
            a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
            a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0],
        ),
        axis=1,
    )
    length = np.sqrt(np.sum(normal**2, axis=1, keepdims=True))
    return normal / np.sqrt(np.where(length > 0, length, 1.0))


def frames(positions: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Triangle frames ``[v2 - v1, v3 - v1, n / sqrt(|n|)]`` as ``(T, 3, 3)`` matrices (columns)."""
    edges = edge_vectors(positions, triangles)
    return np.concatenate((edges, scaled_normals(edges)[:, None]), axis=1).transpose(0, 2, 1)


def degenerate(neutral: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Boolean mask of the zero-area triangles of ``neutral`` (relative to the mesh's extent)."""
    edges = edge_vectors(neutral, triangles)
    doubled_area = np.linalg.norm(np.cross(edges[:, 0], edges[:, 1]), axis=-1)
    scale = float(np.ptp(neutral, axis=0).max()) if neutral.size else 0.0
    return doubled_area <= DEGENERATE_TOLERANCE * max(scale, np.finfo(float).tiny) ** 2


class TransferredEdges:
    """Deformation-transfer targets for the edges of the target's blendshapes, evaluated on demand.

    For template shape k and triangle t the deformation gradient ``G = M(A0 + A_k) M(A0)^-1`` (frames
    with the scaled normal) is applied to the target neutral's frame ``M_0^B``; its first two columns
    minus the neutral's are Li et al.'s ``M_k^{A*} = G M_0^B - M_0^B`` (2010, sec. 3A), the right-hand
    sides of deformation transfer. They are evaluated as ``(M(A0 + A_k) - M(A0)) C`` with
    ``C = M(A0)^-1 E_B`` computed once per triangle, and only for the triangles and shapes asked for: a
    vertex solve needs the triangles around the vertices a shape moves, a small part of the face.

    Parameters
    ----------
    template_neutral : (N, 3) array
    template_deltas : (K, N, 3) array
    target_neutral : (N, 3) array
    triangles : (T, 3) int array

    Notes
    -----
    O(T) to build. Each shape's targets and motion are evaluated once, on all the triangles it moves
    (`on_moving`), and kept: O(P) memory for the P (triangle, shape) pairs a shape moves, less than the
    template's deltas take when shapes are local. A block then costs O(F + P) to gather for F triangles
    and the P pairs of them. Triangles degenerate in the template get zero.
    """

    def __init__(
        self,
        template_neutral: np.ndarray,
        template_deltas: np.ndarray,
        target_neutral: np.ndarray,
        triangles: np.ndarray,
    ) -> None:
        self.triangles = triangles
        self.deltas = template_deltas
        neutral_frames = frames(template_neutral, triangles)
        flat = degenerate(template_neutral, triangles)
        neutral_frames[flat] = np.eye(3)
        target_edges = edge_vectors(target_neutral, triangles).transpose(0, 2, 1)  # (T, 3, 2) columns
        #: (T, 3 frame columns, 2 target edges)
        self.coefficients = np.linalg.solve(neutral_frames, target_edges)
        self.coefficients[flat] = 0.0
        self.neutral_edges = edge_vectors(template_neutral, triangles)
        self.neutral_normals = scaled_normals(self.neutral_edges)
        self._moving: dict[int, np.ndarray] = {}
        self._on_moving: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    def moving(self, shape: int) -> np.ndarray:
        """Sorted triangles with a corner that template shape ``shape`` displaces, kept once computed.

        Elsewhere the shape's edge displacements, and so its targets, are exactly zero.
        """
        found = self._moving.get(shape)
        if found is None:
            displaced = np.any(self.deltas[shape] != 0.0, axis=1)
            found = self._moving[shape] = np.flatnonzero(displaced[self.triangles].any(axis=1))
        return found

    def within(self, faces: np.ndarray, shape: int) -> tuple[np.ndarray, np.ndarray]:
        """Positions in the sorted ``faces`` of the triangles that ``shape`` moves, and their positions
        in `moving`."""
        _, rows, found = np.intersect1d(faces, self.moving(shape), assume_unique=True, return_indices=True)
        return rows, found

    def on_moving(self, shape: int) -> tuple[np.ndarray, np.ndarray]:
        """``(F, 2, 3)`` targets (`edges`) of ``shape`` on the F triangles it moves (`moving`) and the
        ``(F,)`` Frobenius norms of its edge displacements there (`moved`), kept once computed."""
        found = self._on_moving.get(shape)
        if found is None:
            faces = self.moving(shape)
            motion = np.sqrt(np.sum(self.moved(faces, shape) ** 2, axis=(1, 2)))
            found = self._on_moving[shape] = (self.edges(faces, shape), motion)
        return found

    def moved(self, faces: np.ndarray, shape: int) -> np.ndarray:
        """``(F, 2, 3)`` edge displacements of template shape ``shape`` on the triangles ``faces``."""
        corners = self.deltas[shape][self.triangles[faces]]  # (F, 3 corners, 3)
        return corners[:, 1:] - corners[:, :1]

    def edges(self, faces: np.ndarray, shape: int) -> np.ndarray:
        """``(F, 2, 3)`` targets ``M_k^{A*}`` of template shape ``shape`` on the triangles ``faces``."""
        moved = self.moved(faces, shape)
        turned = scaled_normals(self.neutral_edges[faces] + moved) - self.neutral_normals[faces]
        c = self.coefficients[faces][..., None]  # (F, 3 frame columns, 2 target edges, 1)
        return c[:, 0] * moved[:, None, 0] + c[:, 1] * moved[:, None, 1] + c[:, 2] * turned[:, None]

    def block(self, faces: np.ndarray, shapes: np.ndarray) -> np.ndarray:
        """``(F, 2, 3, S)`` targets of every shape in ``shapes`` on every triangle in the sorted ``faces``.

        Only the triangles each shape moves hold targets (`on_moving`); the others are exactly zero.
        """
        result = np.zeros((faces.size, 2, 3, shapes.size))
        for column, shape in enumerate(shapes):
            rows, found = self.within(faces, shape)
            result[rows, :, :, column] = self.on_moving(shape)[0][found]
        return result


def rigid_rotation(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Rotation that best aligns centred ``source`` points with ``target`` (Kabsch).

    Deformation gradients live in world coordinates, so template and target must face the same way;
    rotating the template by this matrix removes a global rigid motion between the two.

    Parameters
    ----------
    source, target : (N, 3) arrays in correspondence.

    Returns
    -------
    (3, 3) proper rotation ``R`` minimising ``sum |R (s - s_mean) - (t - t_mean)|^2``.
    """
    covariance = (target - target.mean(axis=0)).T @ (source - source.mean(axis=0))
    left, _, right = np.linalg.svd(covariance)
    reflection = np.diag([1.0, 1.0, np.sign(np.linalg.det(left @ right)) or 1.0])
    return left @ reflection @ right


def aligned_template(
    template_neutral: np.ndarray, template_deltas: np.ndarray, target_neutral: np.ndarray, align: bool
) -> tuple[np.ndarray, np.ndarray]:
    """The template's neutral and ``(K, N, 3)`` deltas, rotated to face like the target.

    Unchanged (the same arrays) when ``align`` is false.
    """
    if not align:
        return template_neutral, template_deltas
    rotation = rigid_rotation(template_neutral, target_neutral)
    return template_neutral @ rotation.T, template_deltas @ rotation.T
