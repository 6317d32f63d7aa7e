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
        Item indices of each maximal set, ascending, each of size >= 2; ordered by decreasing size,
        then lexicographically.
    n_vertex_rows : int
        Number of vertices active in at least one item (the eq. 3b rows that are not empty).

    Notes
    -----
    O(N I) to read the vertex item sets, a sort of their bit-packed rows to make them unique, and a
    containment test of each unique set against the larger sets that hold its rarest item. Vertices
    are never looped over.
    """
    incidence = sp.csr_matrix(incidence, dtype=bool)
    incidence.sum_duplicates()
    items = np.repeat(np.arange(incidence.shape[0]), np.diff(incidence.indptr))
    vertices = incidence.indices.astype(np.int64)
    n_vertex_rows = int(np.count_nonzero(np.bincount(vertices, minlength=incidence.shape[1])))
    return _maximal_sets(vertices, items, incidence.shape[1], incidence.shape[0]), n_vertex_rows


def restrict_conflict_sets(
    cliques: tuple[np.ndarray, ...], keep: np.ndarray, n_items: int
) -> tuple[np.ndarray, ...]:
    """The maximal conflict sets of the sub-problem over items ``keep`` (renumbered ascending).

    Every vertex item set lies inside a maximal one and every maximal one is a vertex item set, so the
    maximal sets of the restricted problem are the maximal ones among ``{C & keep}`` over the old
    maximal sets ``C``: no vertex is visited again.

    Parameters
    ----------
    cliques : tuple of int arrays
        Maximal conflict sets of the full problem (`maximal_conflict_sets`).
    keep : (I',) int array
        Ascending indices of the items kept.
    n_items : int
        Number of items of the full problem.
    """
    if not cliques or keep.size < 2:
        return ()
    renumber = np.full(n_items, -1, dtype=np.int64)
    renumber[keep] = np.arange(keep.size)
    members = renumber[np.concatenate(cliques)]
    owner = np.repeat(np.arange(len(cliques)), [c.size for c in cliques])
    inside = members >= 0
    return _maximal_sets(owner[inside], members[inside], len(cliques), keep.size)


def _maximal_sets(rows: np.ndarray, cols: np.ndarray, n_rows: int, n_cols: int) -> tuple[np.ndarray, ...]:
    """Distinct inclusion-maximal sets of size >= 2 among the rows of a 0/1 matrix given by its entries.

    Parameters
    ----------
    rows, cols : int arrays
        Positions of the (distinct) ones: row ``rows[e]`` holds item ``cols[e]``.
    n_rows, n_cols : int
        Shape of the matrix.

    Returns
    -------
    tuple of ascending int arrays, by decreasing size, then lexicographically by their index lists.

    Notes
    -----
    Rows are packed into bit words from the entries (never densified), sorted to make them unique,
    and each unique set is compared only with the larger sets that hold its rarest item: a set can be
    contained in no other.
    """
    sizes = np.bincount(rows, minlength=n_rows)
    keep = sizes[rows] >= 2
    rows, cols = rows[keep], cols[keep]
    if rows.size == 0:
        return ()
    words = _bit_words(rows, cols, n_rows, n_cols)
    order = np.lexsort([~words[:, w] for w in reversed(range(words.shape[1]))] + [-sizes])
    order = order[sizes[order] >= 2]
    distinct = np.concatenate([[True], (words[order[1:]] != words[order[:-1]]).any(axis=1)])
    chosen = order[distinct]  # one row per distinct set: decreasing size, then lexicographic
    words, sizes = words[chosen], sizes[chosen]
    position = np.full(n_rows, -1, dtype=np.int64)
    position[chosen] = np.arange(chosen.size)
    mine = position[rows] >= 0
    owner, item = position[rows[mine]], cols[mine]  # entries of the distinct sets
    by_item = np.argsort(item, kind="stable")
    owner, item = owner[by_item], item[by_item]
    holders = np.bincount(item, minlength=n_cols)  # sets holding each item
    holder = owner  # grouped by item
    start = np.concatenate([[0], np.cumsum(holders)])
    by_set = np.argsort(owner, kind="stable")
    owner, item = owner[by_set], item[by_set]  # grouped by set, items ascending
    first = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    rarest = np.minimum.reduceat(holders[item] * n_cols + item, first) % n_cols  # held by the fewest sets
    counts = holders[rarest]
    subset = np.repeat(np.arange(chosen.size), counts)
    offset = np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)
    superset = holder[start[rarest[subset]] + offset]
    larger = sizes[superset] > sizes[subset]  # equal-sized distinct sets never contain each other
    subset, superset = subset[larger], superset[larger]
    contained = ~(words[subset] & ~words[superset]).any(axis=1)
    maximal = np.bincount(subset[contained], minlength=chosen.size) == 0
    return tuple(np.split(item[maximal[owner]].astype(np.int64), np.cumsum(sizes[maximal])[:-1]))


_WORD_BITS = 52  # a sum of distinct powers of two below 2**52 is exact in float64


def _bit_words(rows: np.ndarray, cols: np.ndarray, n_rows: int, n_cols: int) -> np.ndarray:
    """(n_rows, W) uint64 words of each row's bits; item 0 is the highest bit of word 0, so the
    numeric order of the words is the lexicographic order of the sets (reversed)."""
    n_words = -(-n_cols // _WORD_BITS)
    bits = np.ldexp(1.0, _WORD_BITS - 1 - cols % _WORD_BITS)
    summed = np.bincount(rows * n_words + cols // _WORD_BITS, weights=bits, minlength=n_rows * n_words)
    return summed.astype(np.uint64).reshape(n_rows, n_words)
