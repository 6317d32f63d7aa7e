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
from solvers._model import CliqueModel, distinct_bit_rows


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
    item it takes is the first (by weight) of those: with the items renumbered by weight, item p bit
    ``p % 64`` of word ``p // 64``, the lowest set bit of the row's first nonzero candidate word (isolated
    as ``x & -x``, a power of two whose float exponent is exact). Every row takes its next item at once,
    one round per item the most grown row gains, O(G R W) word operations for R distinct rows grown by at
    most G items.
    """
    n_items, n_rows = model.n_items, model.n_rows
    if n_rows == 0:
        return model
    order = np.argsort(-model.weights, kind="stable")
    rank = np.empty(n_items, dtype=np.int64)
    rank[order] = np.arange(n_items)
    # Item order[p] is bit p % 64 of word p // 64: the heaviest candidate of a word is its lowest set bit.
    column = _lowest_first(n_items)[rank]
    width = -(-n_items // 64) * 64
    ranked = np.zeros((n_items, width), dtype=bool)
    ranked[:, column] = unpack_bit_rows(closed, n_items)[order]
    ranked = pack_bit_rows(ranked)
    owner = np.repeat(np.arange(n_rows), np.diff(model.row_starts))
    members = np.zeros((n_rows, width), dtype=bool)
    members[owner, column[model.row_items]] = True
    # Equal rows grow alike: each is grown once (rows cut from an earlier problem's sets repeat a lot).
    member_bits = pack_bit_rows(members)
    distinct = distinct_bit_rows(member_bits)
    grown_bits = member_bits.take(distinct, axis=0)  # (a copy: grown in place)
    # Items conflicting with every member (the members included: neighbourhoods are closed).
    sizes = np.diff(model.row_starts)[distinct]
    starts = np.zeros(distinct.size, dtype=np.int64)
    np.cumsum(sizes[:-1], out=starts[1:])
    entries = np.repeat(model.row_starts[distinct] - starts, sizes) + np.arange(sizes.sum())
    # (``take`` along axis 0: fancy indexing gathers these short rows 2.5 times slower)
    common = np.bitwise_and.reduceat(ranked.take(rank[model.row_items[entries]], axis=0), starts, axis=0)
    finished = []  # the rows grown to maximal cliques
    while grown_bits.shape[0]:
        candidates = common & ~grown_bits
        word = (candidates != 0).argmax(axis=1)
        flat = np.arange(word.size) * common.shape[1] + word  # (each row's first candidate word, flat)
        taken = candidates.reshape(-1).take(flat)  # the next item's word, zero for a maximal row
        open_rows = taken != 0
        n_open = int(np.count_nonzero(open_rows))
        if 2 * n_open < open_rows.size:  # (maximal rows stay until half are: they take nothing more)
            finished.append(grown_bits[~open_rows])
            grown_bits, common = grown_bits[open_rows], common[open_rows]
            word, taken = word[open_rows], taken[open_rows]
            flat = np.arange(word.size) * common.shape[1] + word
            if n_open == 0:
                break
        lowest = taken & (~taken + np.uint64(1))  # (-taken, two's complement; zero for a maximal row)
        grown_bits.reshape(-1)[flat] |= lowest
        # (a maximal row reads some row here: its candidates stay none, whatever it keeps of them)
        common &= ranked.take(word * 64 + np.frexp(lowest.astype(np.float64))[1] - 1, axis=0)  # (2**k: exact)
    maximal = np.concatenate(finished)  # (rows grown alike from different rows are put back in order once)
    grown = pack_bit_rows(unpack_bit_rows(maximal.take(distinct_bit_rows(maximal), axis=0), width)[:, column])
    rows = unpack_bit_rows(grown.take(distinct_bit_rows(grown), axis=0), n_items)
    row_of, items = np.divmod(np.flatnonzero(rows), n_items)  # (as np.nonzero, a third of its time)
    starts = np.zeros(rows.shape[0] + 1, dtype=np.int64)
    np.cumsum(np.bincount(row_of, minlength=rows.shape[0]), out=starts[1:])
    items = items.astype(model.row_items.dtype)
    return CliqueModel(model.weights, starts, items, model.shape_counts, model.cap)


def _lowest_first(n_items: int) -> np.ndarray:
    """(n,) the column of `pack_bit_rows` at which position p is bit ``p % 64`` of word ``p // 64``."""
    position = np.arange(n_items)
    return position - position % 64 + 63 - position % 64


def kernel_neighbourhoods(closed: np.ndarray, kept: np.ndarray, n_items: int) -> np.ndarray:
    """(I', W') uint64 closed neighbourhoods among the items ``kept`` (ascending) of a problem whose closed
    neighbourhoods over its ``n_items`` items are ``closed``, renumbered as ``kept`` orders them."""
    return pack_bit_rows(unpack_bit_rows(closed[kept], n_items)[:, kept])


def kernel_components(closed: np.ndarray) -> list[np.ndarray]:
    """The connected components of a conflict graph, each as its items ascending, in order of their first
    item.

    Parameters
    ----------
    closed : (I, W) uint64 array
        Closed neighbourhoods as bit rows (`packing.PackingProblem.conflict_bits` order).

    Returns
    -------
    list of int arrays
        Every item in exactly one.

    Notes
    -----
    A breadth-first search on the bit rows: each component grows from its first item not yet placed, every
    pass adding the neighbourhoods of the items reached by the last one. Each item's row is read once, so
    O(I W) words in all, plus O(I / 64) words per pass (one pass per step of a component's eccentricity
    from its first item: two or three on the dense kernels of film-sized rigs, I - 1 on a path). SciPy's
    ``connected_components`` needs the bit rows unpacked into a sparse matrix first: 14 times as long on the
    kernels of a 2,000-shape film sequence (75 against 5 ms).
    """
    n_items = closed.shape[0]
    placed = np.zeros(n_items, dtype=bool)
    components = []
    while not placed.all():
        first = int(np.argmin(placed))
        reached = closed[first].copy()
        expanded = np.zeros_like(reached)  # the items whose neighbourhoods are in ``reached``
        expanded[first // 64] = np.uint64(1) << np.uint64(63 - first % 64)
        while (fresh := reached & ~expanded).any():
            items = np.flatnonzero(unpack_bit_rows(fresh[None, :], n_items)[0])
            reached |= np.bitwise_or.reduce(closed.take(items, axis=0), axis=0)
            expanded |= fresh
        members = np.flatnonzero(unpack_bit_rows(reached[None, :], n_items)[0])
        placed[members] = True
        components.append(members)
    return components
