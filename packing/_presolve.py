"""Presolve eq. 3b: from one row per vertex to the distinct maximal conflict sets (DESIGN.md)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


def maximal_conflict_sets(incidence: sp.spmatrix) -> tuple[tuple[np.ndarray, ...], int]:
    """Distinct maximal sets of items that share a vertex.

    Eq. 3b has one row ``sum_k b_k^n w_k <= 1`` per vertex n. A vertex active in fewer than two
    items constrains nothing; two vertices with the same item set give the same row; a row whose
    item set is contained in another row's set is implied by it. What remains is the set of
    inclusion-maximal vertex item sets, which has exactly the same feasible set.

    Parameters
    ----------
    incidence : (I, N) sparse bool matrix
        Active vertices of each item.

    Returns
    -------
    cliques : tuple of int arrays
        Item indices of each maximal set, ascending, each of size >= 2.
    n_vertex_rows : int
        Number of vertices active in at least one item (the eq. 3b rows that are not empty).

    Notes
    -----
    O(nnz) to extract the vertex sets, a sort to make them unique, and one sparse product of the
    unique sets with themselves to find the dominated ones.
    """
    csc = sp.csc_matrix(incidence, dtype=np.int8)
    csc.sum_duplicates()
    counts = np.diff(csc.indptr)
    n_vertex_rows = int(np.count_nonzero(counts))
    shared = np.flatnonzero(counts >= 2)
    if shared.size == 0:
        return (), n_vertex_rows
    columns = csc[:, shared].T.tocsr()  # (V', I): each row is the item set of one vertex
    columns.sort_indices()
    unique_rows = _unique_rows(columns)
    sets = columns[unique_rows]
    sizes = np.diff(sets.indptr)
    overlap = (sets @ sets.T).tocoo()  # |A ∩ B| for every pair of sets
    contained = (overlap.data == sizes[overlap.row]) & (overlap.row != overlap.col)
    # A set equal to another was removed already, so containment here is strict.
    dominated = np.zeros(sets.shape[0], dtype=bool)
    dominated[overlap.row[contained]] = True
    keep = np.flatnonzero(~dominated)
    cliques = tuple(
        np.ascontiguousarray(sets.indices[sets.indptr[r] : sets.indptr[r + 1]], dtype=np.int64) for r in keep
    )
    return tuple(sorted(cliques, key=lambda c: (-c.size, c.tolist()))), n_vertex_rows


def _unique_rows(matrix: sp.csr_matrix) -> np.ndarray:
    """Indices of the first occurrence of each distinct row pattern of a CSR matrix."""
    keys: dict[bytes, int] = {}
    for row in range(matrix.shape[0]):
        key = matrix.indices[matrix.indptr[row] : matrix.indptr[row + 1]].tobytes()
        keys.setdefault(key, row)
    return np.fromiter(keys.values(), dtype=np.int64, count=len(keys))
