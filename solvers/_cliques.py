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

from solvers._model import CliqueModel
from solvers._reduce import pack_bits


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
        The same weights, shape counts and cap; the grown rows, sorted, duplicates removed. Its feasible
        set is the model's.

    Notes
    -----
    Every row is grown at once: the items are visited in order of decreasing weight (ties by index) and
    an item joins each row whose members all conflict with it, O(I R W) word operations for R rows.
    """
    n_items, n_rows = model.n_items, model.n_rows
    if n_rows == 0:
        return model
    sizes = np.diff(model.row_starts)
    owner = np.repeat(np.arange(n_rows), sizes)
    members = np.zeros((n_rows, n_items), dtype=bool)
    members[owner, model.row_items] = True
    member_bits = pack_bits(members)
    # Items conflicting with every member (the members included: neighbourhoods are closed).
    common = np.bitwise_and.reduceat(closed[model.row_items], model.row_starts[:-1], axis=0)
    open_rows = np.flatnonzero((common != member_bits).any(axis=1))
    outside = np.bitwise_or.reduce(common & ~member_bits, axis=0)[None, :]
    candidate = np.unpackbits(outside.astype(">u8").view(np.uint8), axis=1, count=n_items)[0].astype(bool)
    order = np.argsort(-model.weights, kind="stable")
    for item in order[candidate[order]].tolist():  # items that may join some row
        if open_rows.size == 0:
            break
        word, bit = item // 64, np.uint64(1) << np.uint64(63 - item % 64)
        column = common[open_rows, word]
        joins = open_rows[((column & bit) != 0) & ((member_bits[open_rows, word] & bit) == 0)]
        if joins.size:
            member_bits[joins, word] |= bit
            common[joins] &= closed[item]
            still_open = (common[open_rows] != member_bits[open_rows]).any(axis=1)
            open_rows = open_rows[still_open]
    grown = np.unique(member_bits, axis=0)
    rows = np.unpackbits(grown.astype(">u8").view(np.uint8), axis=1, count=n_items).astype(bool)
    row_of, items = np.nonzero(rows)
    starts = np.zeros(rows.shape[0] + 1, dtype=np.int64)
    np.cumsum(np.bincount(row_of, minlength=rows.shape[0]), out=starts[1:])
    items = items.astype(model.row_items.dtype)
    return CliqueModel(model.weights, starts, items, model.shape_counts, model.cap)


def kernel_neighbourhoods(closed: np.ndarray, kept: np.ndarray, n_items: int) -> np.ndarray:
    """(I', W') uint64 closed neighbourhoods among the items ``kept`` (ascending) of a problem whose closed
    neighbourhoods over its ``n_items`` items are ``closed``, renumbered as ``kept`` orders them."""
    bits = np.unpackbits(closed[kept].astype(">u8").view(np.uint8), axis=1, count=n_items).astype(bool)
    return pack_bits(bits[:, kept])
