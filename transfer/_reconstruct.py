"""Vertex positions from per-triangle edge frames by sparse least squares (Sumner & Popovic 2004, sec. 4).

Given desired edge frames ``D_t = [e_2, e_3]`` (3x2, the first two frame columns) for every triangle, the
displacement field ``x`` minimises the gradient energy of the target neutral

    E(x) = sum_t area_t * tr((E_t(x) - D_t) (F_t^T F_t)^-1 (E_t(x) - D_t)^T)

where ``E_t(x)`` are the edges of ``x`` and ``F_t`` those of the neutral: the squared difference of the
piecewise-linear gradients, whose normal matrix is the cotangent Laplacian. Vertices that are static in the
template shape are held at given values (Li et al. 2010, sec. 3A: "to prevent undesirable drifting").

Only the free vertices are unknowns, and their normal equations read only the triangles that touch one of
them: a facial shape moves a small part of the face, so each constraint set is solved as a `FreeBlock` on
its own triangles, factorised once and reused for every right-hand side with the same constraints.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from transfer._frames import degenerate, edge_vectors

if TYPE_CHECKING:
    import scipy.sparse as sp


def static_vertices(deltas: np.ndarray, tolerance: float) -> np.ndarray:
    """Vertices that do not move in each shape.

    Parameters
    ----------
    deltas : (K, N, 3) array
    tolerance : float
        A vertex is static when its displacement is at most ``tolerance`` times the shape's largest.

    Returns
    -------
    (K, N) bool array. Every vertex of an empty shape is static.
    """
    length = displacement_lengths(deltas)
    return length <= tolerance * length.max(axis=1, keepdims=True)


def displacement_lengths(deltas: np.ndarray) -> np.ndarray:
    """``(K, N)`` lengths of the displacements of ``(K, N, 3)`` shapes."""
    return np.sqrt(np.einsum("knc,knc->kn", deltas, deltas))


@dataclass(frozen=True)
class FreeBlock:
    """The normal equations of the free vertices of one constraint set, factorised.

    Attributes
    ----------
    free : (F,) int array
        The free vertices, sorted.
    faces : (S,) int array
        The triangles touching a free vertex, sorted: the only edges the solve reads.
    near : (H,) int array
        The held vertices coupled to a free one, sorted.
    operator : (F, 2S) sparse matrix
        Rows of ``G^T W`` of the free vertices; column ``2s + e`` is edge e of triangle ``faces[s]``.
    coupling : (F, H) sparse matrix
        The Laplacian's free rows on the ``near`` columns.
    factor : SuperLU
        The Laplacian's free block, factorised.
    """

    free: np.ndarray
    faces: np.ndarray
    near: np.ndarray
    operator: sp.csr_matrix
    coupling: sp.csr_matrix
    factor: Any

    @property
    def entries(self) -> int:
        """Stored entries of the factor and the two sparse blocks."""
        return int(self.factor.nnz + self.operator.nnz + self.coupling.nnz)

    def solve(self, edges: np.ndarray, held: np.ndarray) -> np.ndarray:
        """Free-vertex displacements whose edges best match ``edges``, the near vertices held.

        Parameters
        ----------
        edges : (S, 2, 3, M) array
            Desired edge displacements on ``faces`` for M right-hand sides.
        held : (H, 3, M) array
            Displacements of the ``near`` vertices.

        Returns
        -------
        (F, 3, M) array.
        """
        columns = 3 * edges.shape[-1]
        rhs = self.operator @ edges.reshape(-1, columns) - self.coupling @ held.reshape(-1, columns)
        return self.factor.solve(rhs).reshape(self.free.size, 3, -1)

    def respond(self, edges: np.ndarray) -> np.ndarray:
        """`solve` with every near vertex held at rest: the free vertices' response to ``edges`` alone.

        The solve is linear, so ``solve(e + d, h) = solve(e, h) + respond(d)`` up to rounding.

        Parameters
        ----------
        edges : (S, 2, 3, M) array
            Edge displacements on ``faces`` for M right-hand sides.

        Returns
        -------
        (F, 3, M) array.
        """
        rhs = self.operator @ edges.reshape(-1, 3 * edges.shape[-1])
        return self.factor.solve(rhs).reshape(self.free.size, 3, -1)


class FrameReconstruction:
    """Least-squares vertex solve on one target neutral, factorised once per constraint set.

    Parameters
    ----------
    neutral : (N, 3) array
        The target neutral whose triangle metric weighs the energy.
    triangles : (T, 3) int array
    factor_budget : int
        Factorised blocks are kept for later solves while their summed entries (`FreeBlock.entries`) stay
        within this budget (0 keeps none); deformation transfer and every later fit of example-based
        rigging (over all J and, in `transfer.ebfr_full`, every iteration) then share one factorisation
        per constraint set.

    Notes
    -----
    Building costs O(T). Each distinct set of fixed vertices costs one sparse LU factorisation of the
    free block (SuperLU with a minimum-degree ordering of ``A + A^T``), reused for all three
    coordinates and for every shape sharing that set; a solve costs O(S) for the S triangles around the
    free vertices plus the triangular solves.
    """

    def __init__(self, neutral: np.ndarray, triangles: np.ndarray, factor_budget: int = 0) -> None:
        import scipy.sparse as sp
        from scipy.sparse.csgraph import connected_components

        self.triangles = triangles
        self.factor_budget = factor_budget
        self._blocks: dict[bytes, FreeBlock] = {}
        self._entries = 0
        self._blocks_lock = threading.Lock()  # a set-up is shared by the threads of a process
        n_vertices = neutral.shape[0]
        n_triangles = triangles.shape[0]
        edges = edge_vectors(neutral, triangles)
        gram = edges @ np.swapaxes(edges, -1, -2)
        valid = ~degenerate(neutral, triangles)
        area = 0.5 * np.sqrt(np.clip(np.linalg.det(gram), 0.0, None))
        gram[~valid] = np.eye(2)
        metric = area[:, None, None] * np.linalg.inv(gram)
        metric[~valid] = 0.0
        # G: row 2t is v2 - v1 and row 2t+1 is v3 - v1 of triangle t.
        rows = np.repeat(np.arange(2 * n_triangles), 2)
        cols = np.stack((triangles[:, 1], triangles[:, 0], triangles[:, 2], triangles[:, 0]), axis=1).ravel()
        signs = np.tile([1.0, -1.0], 2 * n_triangles)
        gradient = sp.csr_matrix((signs, (rows, cols)), shape=(2 * n_triangles, n_vertices))
        # Block t of W is the 2x2 metric of triangle t on rows and columns 2t, 2t+1.
        pairs = np.arange(2 * n_triangles).reshape(-1, 2)
        block_rows = np.repeat(pairs, 2, axis=1).ravel()
        block_cols = np.tile(pairs, (1, 2)).ravel()
        weight = sp.csr_matrix(
            (metric.ravel(), (block_rows, block_cols)), shape=(2 * n_triangles, 2 * n_triangles)
        )
        #: ``G^T W`` maps ``(2T, 3K)`` edge targets to right-hand sides; ``G^T W G`` is the normal matrix.
        self.weighted_transpose = (gradient.T @ weight).tocsr()
        self.laplacian = (self.weighted_transpose @ gradient).tocsr()
        # Vertices reached only through degenerate triangles carry no energy: they form their own
        # components and get anchored like any other component without a fixed vertex.
        solid = triangles[valid]
        adjacency = sp.csr_matrix(
            (np.ones(solid.size), (solid.ravel(), np.roll(solid, 1, axis=1).ravel())),
            shape=(n_vertices, n_vertices),
        )
        _, self.components = connected_components(adjacency, directed=False)
        #: Row v lists the triangles with corner v.
        self.incidence = sp.csr_matrix(
            (np.ones(triangles.size), (triangles.ravel(), np.repeat(np.arange(n_triangles), 3))),
            shape=(n_vertices, n_triangles),
        )

    def anchored(self, fixed: np.ndarray, preference: np.ndarray) -> np.ndarray:
        """Add one fixed vertex to every connected component that has none.

        Parameters
        ----------
        fixed : (K, N) bool array
        preference : (K, N) float array
            The vertex with the smallest value in the component is chosen (the least moving one).

        Returns
        -------
        (K, N) bool array: ``fixed`` with the anchors added, so every free block is non-singular.
        """
        fixed = fixed.copy()
        for component in np.unique(self.components):
            members = np.flatnonzero(self.components == component)
            loose = ~fixed[:, members].any(axis=1)
            if loose.any():
                choice = members[np.argmin(preference[np.ix_(loose, members)], axis=1)]
                fixed[np.flatnonzero(loose), choice] = True
        return fixed

    def constraints(self, deltas: np.ndarray, tolerance: float) -> np.ndarray:
        """Fixed vertices of each shape: its static vertices plus one anchor per free component.

        Parameters
        ----------
        deltas : (K, N, 3) array
            The template shapes in the target's orientation.
        tolerance : float
            Relative static threshold, see `static_vertices`.

        Returns
        -------
        (K, N) bool array.
        """
        return self.anchored(static_vertices(deltas, tolerance), displacement_lengths(deltas))

    def faces(self, mask: np.ndarray) -> np.ndarray:
        """Sorted triangles touching a vertex left free by ``mask``, the ``(N,)`` held vertices.

        O(F) for the F free vertices' triangles, through the vertex-to-triangle incidence.
        """
        _, corners, _ = _rows(self.incidence, np.flatnonzero(~mask))
        return np.unique(corners)

    def block(self, mask: np.ndarray) -> FreeBlock | None:
        """The factorised `FreeBlock` of the vertices ``mask`` holds; None when it holds every vertex.

        Kept for later calls while the factor budget allows.
        """
        key = np.packbits(mask).tobytes()
        with self._blocks_lock:
            found = self._blocks.get(key)
        if found is not None or mask.all():
            return found
        found = self._factorised(mask)
        with self._blocks_lock:
            if key not in self._blocks and self._entries + found.entries <= self.factor_budget:
                self._blocks[key] = found
                self._entries += found.entries
        return found

    def _factorised(self, mask: np.ndarray) -> FreeBlock:
        """The `FreeBlock` of ``mask``: its rows of the Laplacian and of ``G^T W``, and the factor."""
        import scipy.sparse as sp
        from scipy.sparse.linalg import splu

        n_vertices = mask.size
        free = np.flatnonzero(~mask)
        faces = self.faces(mask)
        indptr, columns, values = _rows(self.laplacian, free)
        # Renumber the columns: free vertices to their place in `free`, held ones to their place in `near`.
        held = mask[columns]
        near = np.unique(columns[held])
        place = np.empty(n_vertices, dtype=np.intp)
        place[free] = np.arange(free.size)
        place[near] = np.arange(near.size)
        inside = _select(indptr, ~held)
        matrix = sp.csr_matrix(
            (values[~held], place[columns[~held]], inside), shape=(free.size, free.size)
        ).tocsc()
        coupling = sp.csr_matrix(
            (values[held], place[columns[held]], _select(indptr, held)), shape=(free.size, near.size)
        )
        factor = splu(
            matrix, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True}
        )
        # Every nonzero of a free vertex's row of G^T W is an edge of a triangle touching it: renumber the
        # columns to the edges of `faces` (a monotone map, so each row keeps its order and its sums).
        indptr, columns, values = _rows(self.weighted_transpose, free)
        local = 2 * np.searchsorted(faces, columns // 2) + columns % 2
        operator = sp.csr_matrix((values, local, indptr), shape=(free.size, 2 * faces.size))
        return FreeBlock(free, faces, near, operator, coupling, factor)


def _rows(matrix: sp.csr_matrix, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``indptr, indices, data`` of the given rows of a CSR matrix, in order."""
    counts = matrix.indptr[rows + 1] - matrix.indptr[rows]
    indptr = np.concatenate(([0], np.cumsum(counts)))
    positions = np.repeat(matrix.indptr[rows] - indptr[:-1], counts) + np.arange(indptr[-1])
    return indptr, matrix.indices[positions], matrix.data[positions]


def _select(indptr: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """The ``indptr`` of CSR rows (``indptr``) that keep only their entries where ``keep`` holds."""
    return np.concatenate(([0], np.cumsum(keep)))[indptr]


def constraint_groups(fixed: np.ndarray) -> list[np.ndarray]:
    """Shapes sharing one set of fixed vertices, as sorted index arrays in order of first appearance.

    Parameters
    ----------
    fixed : (K, N) bool array

    Returns
    -------
    list of int arrays partitioning ``range(K)``.
    """
    groups: dict[bytes, list[int]] = {}
    for shape, mask in enumerate(np.packbits(fixed, axis=1)):
        groups.setdefault(mask.tobytes(), []).append(shape)
    return [np.array(members) for members in groups.values()]
