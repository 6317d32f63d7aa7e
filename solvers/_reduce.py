"""Exact reductions of eq. 3 before a backend sees it: dominated items out, conflict-free items in.

Eq. 3 (after the presolve of `packing`) is a maximum-weight independent set on the item conflict graph:
two items conflict when they share a conflict set. Two classic reductions keep the set of optimal packings
exactly as it is while shrinking the model every exact backend builds (the first expressions of a
film-sized rig have hundreds of items of which more than half are dominated):

* **Domination.** With ``N[i]`` the closed neighbourhood of item i (i and the items it conflicts with), an
  item j conflicting with i, with ``N[j]`` inside ``N[i]``, a strictly larger weight and (under a cap) no
  more blendshapes, *dominates* i: swapping i for j in any packing keeps it feasible and makes it strictly
  better, so no optimal packing holds i.
* **Isolation.** Without a cap, an item of positive weight that conflicts with no other item is in every
  optimal packing.

Both are applied until neither changes anything. Domination is transitive along strictly increasing
weights, so every dominated item of a round can go at once.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from packing import pack_bit_rows
from solvers._model import CliqueModel

if TYPE_CHECKING:
    from packing import PackingProblem


@dataclass(frozen=True)
class Reduction:
    """What is left of a problem after the reductions.

    Attributes
    ----------
    problem : PackingProblem
        The problem reduced.
    kept : (I',) int array
        Items of the original problem that form the kernel, ascending (kernel item ``r`` is ``kept[r]``).
    taken : (T,) int array
        Items of the original problem that are in every optimal packing (isolated ones), ascending.
    """

    problem: PackingProblem
    kept: np.ndarray
    taken: np.ndarray

    @cached_property
    def model(self) -> CliqueModel:
        """The presolved model of the kernel, with the conflict sets that ``problem.restrict(kept)`` would
        have (distinct, maximal: derived on first use)."""
        keep = None if self.kept.size == self.problem.n_items else self.kept
        return CliqueModel.from_problem(self.problem, keep)

    def cut_model(self) -> CliqueModel:
        """The model of the kernel whose rows are conflict sets cut to the kernel's items: the same feasible
        packings as `model`, its rows cliques too, some possibly inside others. A cheap base for rows that
        are grown to maximal cliques anyway (`solvers._cliques.grown_cliques`).

        The sets are those of `packing.PackingProblem.conflict_view`: along an expression sequence, the
        sets of an earlier problem, so that the problem's own maximal sets are never derived (the largest
        cost of the sequence's problems after the backend's search). Only the sets holding a kernel item
        are visited (`packing.ConflictSets.holders`, a quarter of the sets' members on the largest problems
        of a film-sized sequence): the kernel's entries are gathered item by item and sorted by set, in the
        sets' order, with one counting sort (a sparse transpose)."""
        import scipy.sparse as sp

        view = self.problem.conflict_view
        holder_starts, holder_sets = view.sets.holders
        outer = view.items[self.kept]
        lengths = holder_starts[outer + 1] - holder_starts[outer]
        ends = np.cumsum(lengths)
        entries = np.repeat(holder_starts[outer] - ends + lengths, lengths) + np.arange(
            ends[-1] if ends.size else 0
        )
        by_item = sp.csr_matrix(
            (np.ones(entries.size, dtype=np.int8), holder_sets[entries], np.concatenate([[0], ends])),
            shape=(self.kept.size, len(view.sets)),
        )
        by_set = by_item.tocsc()  # each set's kernel items, ascending
        sizes = np.diff(by_set.indptr)
        wide = sizes >= 2  # (a set cut to one item constrains nothing)
        starts = np.zeros(np.count_nonzero(wide) + 1, dtype=np.int64)
        np.cumsum(sizes[wide], out=starts[1:])
        members = by_set.indices[np.repeat(wide, sizes)].astype(np.int64)
        weights = np.asarray(self.problem.weights, dtype=np.float64)[self.kept]
        counts = self.problem.item_shape_counts[self.kept]
        cap = self.problem.cap
        cap = cap if cap is not None and cap < counts.sum() else None
        return CliqueModel(weights, starts, members, counts, cap)

    def items(self, kernel_items: tuple[int, ...]) -> tuple[int, ...]:
        """Items of the original problem for a packing of the kernel: those items plus the taken ones."""
        chosen = np.concatenate([self.taken, self.kept[np.asarray(kernel_items, dtype=np.int64)]])
        return tuple(sorted(chosen.tolist()))


def reduce_problem(problem: PackingProblem, cap_binds: bool) -> Reduction:
    """Remove dominated items and take isolated ones (see the module notes) until nothing changes.

    Parameters
    ----------
    problem : PackingProblem
        Its weights are the objective the backends maximise (tie-break included).
    cap_binds : bool
        Whether the cap of sec. 6 can bind; then an item dominates only items with at least as many
        blendshapes, and isolated items are left to the backend.

    Returns
    -------
    Reduction

    Notes
    -----
    Neighbourhoods are the problem's `PackingProblem.conflict_bits` (64 items a word; along an expression
    sequence each problem derives them from the previous one's); each round compares the conflicting pairs
    whose weights and degrees allow domination and whose would-be dominator lost a neighbour since the last
    round, read from a dense (I, I) matrix of the pairs that weights and shapes allow: O(I^2 + P W) a round
    for P such pairs.
    """
    weights = np.asarray(problem.weights, dtype=np.float64)
    kept, taken = reduce_graph(weights, problem.item_shape_counts, problem.conflict_bits, cap_binds)
    return Reduction(problem, kept, taken)


def reduce_graph(
    weights: np.ndarray, counts: np.ndarray, closed: np.ndarray, cap_binds: bool
) -> tuple[np.ndarray, np.ndarray]:
    """`reduce_problem` on the arrays of a conflict graph: the items left and the items taken.

    Parameters
    ----------
    weights, counts : (I,) arrays
        Item weights (eq. 3a) and blendshapes per item.
    closed : (I, W) uint64 array
        Closed neighbourhoods as bit rows (`packing.PackingProblem.conflict_bits` order).
    cap_binds : bool
        As in `reduce_problem`.

    Returns
    -------
    kept, taken : int arrays, ascending
        The kernel's items and the isolated items every optimal packing holds.
    """
    n_items = weights.size
    everything = np.arange(n_items)
    if n_items == 0:
        return everything, everything
    # may_dominate[i, j]: j conflicts with i, weighs more and (under a cap) has no more shapes.
    may_dominate = np.unpackbits(closed.astype(">u8").view(np.uint8), axis=1, count=n_items).astype(bool)
    may_dominate &= weights[None, :] > weights[:, None]
    if cap_binds:
        may_dominate &= counts[None, :] <= counts[:, None]
    alive = np.ones(n_items, dtype=bool)
    taken = np.zeros(n_items, dtype=bool)
    previous_degree = np.full(n_items, -1, dtype=np.int64)
    while True:
        live = closed & pack_bit_rows(alive[None, :])[0]
        degree = np.bitwise_count(live).sum(axis=1, dtype=np.int64) - 1
        isolated = alive & (degree == 0) & (weights > 0) if not cap_binds else np.zeros(n_items, dtype=bool)
        # N[j] inside N[i] can only become true when N[j] shrank: only the would-be dominators j that lost a
        # neighbour since the last round are compared again, and only with the live items i of no smaller
        # degree (a third of the reductions' time when all the matrix's pairs were listed once).
        rows = np.flatnonzero(alive)
        columns = np.flatnonzero(alive & (degree != previous_degree))
        possible = may_dominate.take(rows, axis=0).take(columns, axis=1)  # (np.ix_ is 7 times slower)
        possible &= degree[columns][None, :] <= degree[rows][:, None]
        candidate, dominator = np.divmod(np.flatnonzero(possible), columns.size)  # (as np.nonzero, faster)
        dominated = _dominated(live, rows[candidate], columns[dominator])
        if not (isolated.any() or dominated.any()):
            break
        taken |= isolated
        alive &= ~(isolated | dominated)
        previous_degree = degree
    return np.flatnonzero(alive), np.flatnonzero(taken)


def _dominated(live: np.ndarray, candidate: np.ndarray, dominator: np.ndarray) -> np.ndarray:
    """(I,) bool: the items ``candidate[p]`` with ``N[dominator[p]]`` inside ``N[candidate[p]]``, where
    ``live`` are the closed neighbourhoods among the live items."""
    for word in np.ascontiguousarray(live.T):  # N[j] & ~N[i], word by word, on the pairs still inside
        inside = (word[dominator] & ~word[candidate]) == 0
        candidate, dominator = candidate[inside], dominator[inside]
    dominated = np.zeros(live.shape[0], dtype=bool)
    dominated[candidate] = True
    return dominated
