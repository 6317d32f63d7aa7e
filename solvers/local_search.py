"""Greedy packing improved by (1,2)-swap local search (plugin ``greedy-swap``; beyond the paper).

Algorithm 2 (sec. 4.5.2) is fast but its first expression falls 0-23% short of the optimum on synthetic
paper-sized rigs. This heuristic starts from two greedy packings (Algorithm 2's order and
decreasing weight), then repeatedly applies the best improving move on the item conflict graph:

* *add* an item none of whose conflicting items is chosen;
* *(1,1)-swap*: drop one chosen item ``u`` and add one item whose only chosen conflict is ``u``;
* *(1,2)-swap*: drop ``u`` and add two mutually compatible such items,

all within the cap (sec. 6), until no move improves eq. 3a. It keeps the better of the two results.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from packing import Termination
from solvers._base import Availability, Capabilities, Result, Stopwatch, distribution_version
from solvers.greedy import PROJECT_DISTRIBUTION, greedy_items, greedy_order

if TYPE_CHECKING:
    import scipy.sparse as sp

    from packing import PackingProblem

#: An improvement smaller than this (relative to the total weight) is treated as none.
IMPROVEMENT_TOLERANCE = 1e-12


class _Packing:
    """Mutable packing on the conflict graph: chosen items, chosen-neighbour counts, cap room."""

    def __init__(
        self,
        weights: np.ndarray,
        counts: np.ndarray,
        cap: int | None,
        adjacency: sp.csr_matrix,
        start: Iterable[int],
        dense: np.ndarray | None = None,
    ) -> None:
        self.weights = weights
        self.counts = counts
        self.adjacency = adjacency
        self.dense = dense  # the adjacency as an (I, I) bool array, made on first use when not given
        self.chosen = np.zeros(weights.size, dtype=bool)
        self.tight = np.zeros(weights.size, dtype=np.int64)  # chosen neighbours of each item
        self.room = np.inf if cap is None else float(cap)
        self.tolerance = IMPROVEMENT_TOLERANCE * max(1.0, float(np.abs(self.weights).sum()))
        for item in start:
            self.add(item)

    def neighbours(self, item: int) -> np.ndarray:
        return self.adjacency.indices[self.adjacency.indptr[item] : self.adjacency.indptr[item + 1]]

    def add(self, item: int) -> None:
        self.chosen[item] = True
        self.tight[self.neighbours(item)] += 1
        self.room -= self.counts[item]

    def drop(self, item: int) -> None:
        self.chosen[item] = False
        self.tight[self.neighbours(item)] -= 1
        self.room += self.counts[item]

    def fill(self) -> bool:
        """Add free items (no chosen conflict, positive weight) by decreasing weight while the cap allows."""
        free = np.flatnonzero(~self.chosen & (self.tight == 0) & (self.weights > self.tolerance))
        added = False
        for item in free[np.argsort(-self.weights[free], kind="stable")].tolist():
            if self.tight[item] == 0 and self.counts[item] <= self.room:
                self.add(item)
                added = True
        return added

    def best_swap(self, dropped: int) -> tuple[float, tuple[int, ...]]:
        """Best gain of replacing ``dropped`` by one or two items whose only chosen conflict it is."""
        near = self.neighbours(dropped)
        near = near[~self.chosen[near] & (self.tight[near] == 1)]
        room = self.room + self.counts[dropped]
        near = near[self.counts[near] <= room]
        if near.size == 0:
            return 0.0, ()
        gain_one = self.weights[near] - self.weights[dropped]
        best = int(np.argmax(gain_one))
        gain, added = float(gain_one[best]), (int(near[best]),)
        if near.size >= 2:
            if self.dense is None:
                self.dense = self.adjacency.toarray()
            compatible = ~self.dense[np.ix_(near, near)]
            pair_weight = self.weights[near][:, None] + self.weights[near][None, :]
            fits = (self.counts[near][:, None] + self.counts[near][None, :]) <= room
            allowed = np.triu(compatible & fits, k=1)
            if allowed.any():
                flat = int(np.argmax(np.where(allowed, pair_weight, -np.inf)))
                a, b = divmod(flat, near.size)
                pair_gain = float(pair_weight[a, b] - self.weights[dropped])
                if pair_gain > gain:
                    gain, added = pair_gain, (int(near[a]), int(near[b]))
        return gain, added

    def improve(self) -> None:
        """Apply improving add / (1,1) / (1,2) moves until none is left."""
        self.fill()
        improved = True
        while improved:
            improved = False
            for dropped in np.flatnonzero(self.chosen).tolist():
                if not self.chosen[dropped]:
                    continue
                gain, added = self.best_swap(dropped)
                if gain > self.tolerance:
                    self.drop(dropped)
                    for item in added:
                        self.add(item)
                    self.fill()
                    improved = True

    def items(self) -> tuple[int, ...]:
        return tuple(np.flatnonzero(self.chosen).tolist())


def swap_local_search(problem: PackingProblem, start: tuple[int, ...] | None = None) -> tuple[int, ...]:
    """Items of a packing improved by add, (1,1)- and (1,2)-swaps until it is locally optimal.

    Parameters
    ----------
    problem : PackingProblem
    start : tuple of int, optional
        A valid packing to start from; default Algorithm 2's and the weight-ordered greedy packings,
        keeping the better result.

    Notes
    -----
    Each accepted move raises eq. 3a, so the search terminates; one pass costs O(sum of squared
    degrees of the chosen items) on the conflict graph.
    """
    from packing import conflict_graph

    adjacency = conflict_graph(problem)
    starts = (
        [start]
        if start is not None
        else [
            greedy_items(problem, order=greedy_order(problem)),
            greedy_items(problem, order=np.argsort(-problem.weights, kind="stable")),
        ]
    )
    results = [
        locally_optimal(problem.weights, problem.item_shape_counts, problem.cap, adjacency, initial)
        for initial in starts
    ]
    return max(results, key=problem.objective)


def locally_optimal(
    weights: np.ndarray,
    counts: np.ndarray,
    cap: int | None,
    adjacency: sp.csr_matrix,
    start: Iterable[int],
    dense: np.ndarray | None = None,
) -> tuple[int, ...]:
    """A packing improved from ``start`` by add, (1,1)- and (1,2)-swaps until no move raises eq. 3a.

    Parameters
    ----------
    weights, counts : (I,) arrays
        Item weights (eq. 3a) and blendshapes per item (the cap row's coefficients).
    cap : int or None
        At most this many blendshapes (sec. 6).
    adjacency : (I, I) bool CSR matrix
        The item conflict graph without self loops, indices sorted.
    start : iterable of int
        A valid packing.
    dense : (I, I) bool array, optional
        ``adjacency`` as a dense array, when the caller has it (else made on first need).

    Returns
    -------
    tuple of int
        The items, ascending.
    """
    packing = _Packing(weights, counts, cap, adjacency, start, dense)
    packing.improve()
    return packing.items()


class GreedySwapSolver:
    """Greedy packing plus (1,2)-swap local search: a stronger heuristic than Algorithm 2.

    Deterministic, no optimality proof (``bound`` is None); see `swap_local_search`.
    """

    name: ClassVar[str] = "greedy-swap"
    capabilities: ClassVar[Capabilities] = Capabilities(exact=False, time_limit=False)

    @classmethod
    def availability(cls) -> Availability:
        """Always available: numpy and scipy only."""
        return Availability.available(distribution_version(PROJECT_DISTRIBUTION))

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Result:
        """Run the local search to a local optimum (``time_limit`` and ``seed`` are accepted and unused)."""
        clock = Stopwatch()
        items = swap_local_search(problem) if problem.n_items else ()
        return Result(items, Termination.COMPLETED, None, 0.0, clock.lap())
