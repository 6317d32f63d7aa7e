"""Vertex positions from per-triangle edge frames by sparse least squares (Sumner & Popovic 2004, sec. 4).

Given desired edge frames ``D_t = [e_2, e_3]`` (3x2, the first two frame columns) for every triangle, the
displacement field ``x`` minimises the gradient energy of the target neutral

    E(x) = sum_t area_t * tr((E_t(x) - D_t) (F_t^T F_t)^-1 (E_t(x) - D_t)^T)

where ``E_t(x)`` are the edges of ``x`` and ``F_t`` those of the neutral: the squared difference of the
piecewise-linear gradients, whose normal matrix is the cotangent Laplacian. Vertices that are static in the
template shape are held at given values (Li et al. 2010, sec. 3A: "to prevent undesirable drifting").
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import splu

from transfer._frames import degenerate, edge_vectors


def static_vertices(deltas: np.ndarray, tolerance: float) -> np.ndarray:
    """Vertices that do not move in each shape.

    Parameters
    ----------
    deltas : (N, 3, K) array, vertex-major
    tolerance : float
        A vertex is static when its displacement is at most ``tolerance`` times the shape's largest.

    Returns
    -------
    (K, N) bool array. Every vertex of an empty shape is static.
    """
    length = np.sqrt(np.sum(deltas**2, axis=1)).T
    return length <= tolerance * length.max(axis=1, keepdims=True)


class FrameReconstruction:
    """Least-squares vertex solve on one target neutral, factorised once per constraint set.

    Parameters
    ----------
    neutral : (N, 3) array
        The target neutral whose triangle metric weighs the energy.
    triangles : (T, 3) int array
    factor_budget : int
        Factorisations are kept for later `solve` calls while their summed number of stored entries
        stays within this budget (0 keeps none); repeated solves with the same constraints (the
        alternating optimisation of `transfer.ebfr_full`) then skip the factorisation.

    Notes
    -----
    Building costs O(T). Each distinct set of fixed vertices costs one sparse LU factorisation of the
    free block (SuperLU with a minimum-degree ordering of ``A + A^T``), reused for all three
    coordinates and for every shape sharing that set.
    """

    def __init__(self, neutral: np.ndarray, triangles: np.ndarray, factor_budget: int = 0) -> None:
        self.factor_budget = factor_budget
        self._factors: dict[bytes, tuple[np.ndarray, np.ndarray, sp.csr_matrix, object]] = {}
        self._factor_entries = 0
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
        deltas : (N, 3, K) array
            The template shapes, vertex-major, in the target's orientation.
        tolerance : float
            Relative static threshold, see `static_vertices`.

        Returns
        -------
        (K, N) bool array.
        """
        return self.anchored(static_vertices(deltas, tolerance), np.sqrt(np.sum(deltas**2, axis=1)).T)

    def solve(self, edge_targets: np.ndarray, fixed: np.ndarray, fixed_values: np.ndarray) -> np.ndarray:
        """Displacements whose edges best match ``edge_targets``, with ``fixed`` vertices held.

        Parameters
        ----------
        edge_targets : (T, 2, 3, K) array
            Desired edge displacements ``v2 - v1``, ``v3 - v1`` of each triangle and shape.
        fixed : (K, N) bool array
            Vertices held at ``fixed_values``; every connected component needs at least one
            (see `constraints`).
        fixed_values : (N, 3, K) array

        Returns
        -------
        (N, 3, K) array of displacements, vertex-major.
        """
        n_shapes = edge_targets.shape[-1]
        rhs = (self.weighted_transpose @ edge_targets.reshape(-1, 3 * n_shapes)).reshape(-1, 3, n_shapes)
        result = np.where(fixed.T[:, None, :], fixed_values, 0.0)
        groups: dict[bytes, list[int]] = {}
        for shape, mask in enumerate(np.packbits(fixed, axis=1)):
            groups.setdefault(mask.tobytes(), []).append(shape)
        for members in groups.values():
            mask = fixed[members[0]]
            if mask.all():
                continue
            free, held, coupling, factor = self._factorised(mask)
            coordinates = np.arange(3)
            known = result[np.ix_(held, coordinates, members)].reshape(held.size, -1)
            b = rhs[np.ix_(free, coordinates, members)].reshape(free.size, -1) - coupling @ known
            result[np.ix_(free, coordinates, members)] = factor.solve(b).reshape(free.size, 3, len(members))
        return result

    def _factorised(self, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray, sp.csr_matrix, object]:
        """Free and held vertices, their coupling block and the factorised free block for ``mask``."""
        key = mask.tobytes()
        if key in self._factors:
            return self._factors[key]
        free = np.flatnonzero(~mask)
        held = np.flatnonzero(mask)
        block = self.laplacian[free]
        factor = splu(
            block[:, free].tocsc(),
            permc_spec="MMD_AT_PLUS_A",
            diag_pivot_thresh=0.0,
            options={"SymmetricMode": True},
        )
        entry = (free, held, block[:, held], factor)
        size = factor.nnz
        if self._factor_entries + size <= self.factor_budget:
            self._factors[key] = entry
            self._factor_entries += size
        return entry
