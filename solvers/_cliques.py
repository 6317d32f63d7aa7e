"""Clique rows grown to maximal cliques of the conflict graph: the same packings, a tighter LP.

The presolve of `packing` turns eq. 3b into one at-most-one row per maximal *vertex* conflict set: the items
active at one vertex. On film-sized rigs the item conflict graph is dense (an item of the largest problems
conflicts with a third of the others) and holds far larger cliques than any one vertex shows: three items
that overlap pairwise at three different vertices share no vertex. Each row is a clique of the conflict
graph, so every item that conflicts with all of its members may join it: the grown row still allows at most
one of items that pairwise conflict, so the feasible packings (and the optima) are exactly those of the
given rows, while the linear relaxation (and CP-SAT's LP-based bounds) gets much tighter. This is the
clique lifting of MIP preprocessing (Atamturk, Nemhauser and Savelsbergh 2000, "Conflict graphs in solving
integer programming problems", sec. 3).
"""

from __future__ import annotations

import numpy as np

from packing import pack_bit_rows, unpack_bit_rows
from solvers._model import CliqueModel


def grown_cliques(model: CliqueModel, closed: np.ndarray) -> CliqueModel:
    """The model with each clique row grown, greedily by weight, to a maximal clique of the conflict graph.

    Parameters
    ----------
    model : CliqueModel
        Its rows are cliques of the conflict graph ``closed`` (every pair of a row's items conflicts).
    closed : (I, W) uint64 array
        Closed neighbourhoods of the model's items as bit rows (`packing.PackingProblem.conflict_bits`
        order: item j is bit ``63 - j % 64`` of word ``j // 64``).

    Returns
    -------
    CliqueModel
        The same weights, shape counts and cap; the grown rows, sorted (as bit rows, item 0 the highest
        bit), duplicates removed. Its feasible set is the model's.

    Notes
    -----
    Each row visits the items in order of decreasing weight (ties by index) and takes every item that
    conflicts with all of its members so far. Since the items a row may still take only shrink, the next
    item it takes is the first (by weight) of those: with the items renumbered by weight, the highest set
    bit of the row's candidate words. Every row takes its next item at once, one round per item the most
    grown row gains, O(G R W) word operations for R rows grown by at most G items.
    """
    n_items, n_rows = model.n_items, model.n_rows
    if n_rows == 0:
        return model
    order = np.argsort(-model.weights, kind="stable")
    rank = np.empty(n_items, dtype=np.int64)
    rank[order] = np.arange(n_items)
    ranked = pack_bit_rows(unpack_bit_rows(closed, n_items)[order][:, order])  # item order[p] is bit p
    owner = np.repeat(np.arange(n_rows), np.diff(model.row_starts))
    members = np.zeros((n_rows, n_items), dtype=bool)
    members[owner, rank[model.row_items]] = True
    # Equal rows grow alike: each is grown once (rows cut from an earlier problem's sets repeat a lot).
    member_bits = pack_bit_rows(members)
    distinct = _distinct_rows(member_bits)
    member_bits, n_rows = member_bits[distinct], distinct.size
    # Items conflicting with every member (the members included: neighbourhoods are closed).
    common = np.bitwise_and.reduceat(ranked[rank[model.row_items]], model.row_starts[:-1], axis=0)[distinct]
    growing, grown_bits = np.arange(n_rows), member_bits.copy()  # the rows still growing, their members
    while growing.size:
        candidates = common & ~grown_bits
        nonzero = candidates != 0
        open_rows = nonzero.any(axis=1)
        if not open_rows.all():
            member_bits[growing[~open_rows]] = grown_bits[~open_rows]
            growing, grown_bits, common = growing[open_rows], grown_bits[open_rows], common[open_rows]
            candidates, nonzero = candidates[open_rows], nonzero[open_rows]
        if growing.size == 0:
            break
        row, word = np.arange(growing.size), nonzero.argmax(axis=1)
        bit = _highest_bit(candidates[row, word])
        grown_bits[row, word] |= np.left_shift(np.uint64(1), bit.astype(np.uint64))
        common &= ranked[word * 64 + 63 - bit]
    by_item = np.zeros((n_rows, n_items), dtype=bool)
    by_item[:, order] = unpack_bit_rows(member_bits, n_items)
    grown = pack_bit_rows(by_item)
    rows = unpack_bit_rows(grown[_distinct_rows(grown)], n_items)
    row_of, items = np.divmod(np.flatnonzero(rows), n_items)  # (as np.nonzero, a third of its time)
    starts = np.zeros(rows.shape[0] + 1, dtype=np.int64)
    np.cumsum(np.bincount(row_of, minlength=rows.shape[0]), out=starts[1:])
    items = items.astype(model.row_items.dtype)
    return CliqueModel(model.weights, starts, items, model.shape_counts, model.cap)


def _distinct_rows(words: np.ndarray) -> np.ndarray:
    """Indices of the distinct rows of an (R, W) uint64 array, the first of each in order of the rows
    sorted lexicographically by word (as ``np.unique(words, axis=0, return_index=True)[1]`` over the
    numbers; a sort of W integer keys, where that one compares the rows as opaque bytes)."""
    order = np.lexsort(words.T[::-1])  # (word 0 the primary key; stable, so the first of equal rows first)
    ordered = words[order]
    first = np.ones(order.size, dtype=bool)
    first[1:] = (ordered[1:] != ordered[:-1]).any(axis=1)
    return order[first]


def _highest_bit(words: np.ndarray) -> np.ndarray:
    """(n,) int64: index (0 = least significant) of the highest set bit of each nonzero uint64 word, from
    the exact binary exponents of its two 32-bit halves."""
    high = np.frexp((words >> np.uint64(32)).astype(np.float64))[1]
    low = np.frexp((words & np.uint64(0xFFFFFFFF)).astype(np.float64))[1]
    return np.where(high > 0, high + 31, low - 1).astype(np.int64)


def kernel_neighbourhoods(closed: np.ndarray, kept: np.ndarray, n_items: int) -> np.ndarray:
    """(I', W') uint64 closed neighbourhoods among the items ``kept`` (ascending) of a problem whose closed
    neighbourhoods over its ``n_items`` items are ``closed``, renumbered as ``kept`` orders them."""
    return pack_bit_rows(unpack_bit_rows(closed[kept], n_items)[:, kept])
