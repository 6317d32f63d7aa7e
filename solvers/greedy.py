"""Greedy set packing (Carrigan et al. 2020, sec. 4.5.2, Algorithm 2), strict and with allowed overlap.

Plugins ``greedy`` (`GreedySolver`) and ``greedy-overlap`` (`GreedyOverlapSolver`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from packing import Termination
from registry import checked_settings
from solvers._base import Availability, Capabilities, Result, Setting, Stopwatch, distribution_version
from solvers._open import OpenExpression

if TYPE_CHECKING:
    from packing import ConflictSets, PackingProblem

#: Distribution that ships the built-in pure-numpy solvers (their version is the project's).
PROJECT_DISTRIBUTION = "expression-packing-harness"


def greedy_scores(problem: PackingProblem) -> np.ndarray:
    """Algorithm 2's selection key ``(lambda_max - lambda_k) * |b_k|`` of every item (smaller first).

    ``lambda_k`` is the item's weight per blendshape (a symmetry pair's weight is the sum of its two
    shapes') and ``|b_k|`` its active vertex count (the union for a pair, sec. 4.4). The paper fixes
    ``lambda_max = 1``, which assumes importance in [0, 1] (``beta = 0``, eq. 4); here
    ``lambda_max = max(1, max_k lambda_k)`` so that the key stays non-negative for any weights.

    Returns
    -------
    (I,) float array.
    """
    return _scores(problem, problem.item_shape_counts)


def _scores(problem: PackingProblem, counts: np.ndarray) -> np.ndarray:
    """Algorithm 2's key ``(lambda_max - lambda_k) |b_k|`` on the unperturbed importance (sec. 4.5.2)."""
    weights = problem.weights if problem.tie_break is None else problem.weights - problem.tie_break
    per_shape = weights / counts
    lambda_max = max(1.0, float(per_shape.max(initial=0.0)))
    return (lambda_max - per_shape) * problem.item_active_counts


def greedy_order(problem: PackingProblem, counts: np.ndarray | None = None) -> np.ndarray:
    """Items in Algorithm 2's visiting order (sec. 4.5.2).

    By increasing key (`greedy_scores`); equal keys (e.g. every weight 1 without importance, where the
    paper's key is 0 for all) go by fewer active vertices first, which packs the most blendshapes, then by
    the problem's deterministic tie-break, then by index.
    """
    counts = problem.item_shape_counts if counts is None else counts
    tie_break = np.zeros(problem.n_items) if problem.tie_break is None else problem.tie_break
    keys = (np.arange(problem.n_items), -tie_break, problem.item_active_counts, _scores(problem, counts))
    return np.lexsort(keys)


def greedy_items(
    problem: PackingProblem, overlap: float = 0.0, order: np.ndarray | None = None
) -> tuple[int, ...]:
    """Items chosen by Algorithm 2 (sec. 4.5.2).

    Items are visited in `greedy_order`. An item is added when its active
    vertices overlapping the expression built so far are at most ``overlap * |b_k|``, the cap (sec. 6)
    still has room for its shapes and no chosen item is apart from it; otherwise it is dropped. Since the
    expression only grows, this is the
    paper's "remove every remaining blendshape that overlaps" after each addition.

    Parameters
    ----------
    problem : PackingProblem
    overlap : float in [0, 1)
        Allowed fraction of an item's active vertices already active in the expression; 0 is the strict
        packing of eq. 3b.
    order : (I,) int array, optional
        Visiting order; default the increasing Algorithm 2 key.

    Returns
    -------
    tuple of int, the chosen items in the order they were added.

    Notes
    -----
    O(nnz(incidence) + I log I): each item's vertex list is read once.
    """
    if not 0.0 <= overlap < 1.0:
        raise ValueError(f"overlap must be a fraction in [0, 1), got {overlap!r}")
    counts = problem.item_shape_counts
    if order is None:
        order = greedy_order(problem, counts)
    if overlap == 0.0:
        return _strict_greedy(problem, order, counts)
    expression = OpenExpression(problem, overlap)
    for item in order.tolist():
        if expression.fits(item):
            expression.add(item)
    return expression.items


def _strict_greedy(problem: PackingProblem, order: np.ndarray, counts: np.ndarray) -> tuple[int, ...]:
    """`greedy_items` without overlap, on conflict sets instead of the vertices.

    Two items share a vertex iff they share a conflict set, so adding an item blocks its neighbours in
    the conflict graph, and an item with more shapes than the cap leaves room for is skipped: no vertex is
    read and only the neighbours of the chosen items are visited. The sets are
    `PackingProblem.conflict_view`'s (those of a problem this one was restricted from, over its item
    numbering), so that the sequence's restricted problems never derive their own. The items are held by
    their place in ``order``, so that the next item not blocked is found by one search of the places after
    the last one visited.

    The neighbours are the sets' neighbour lists (`packing.ConflictSets.neighbours`) when they
    are made or worth making: for a restricted problem, whose sets serve the whole lineage of an expression
    sequence (at 2,000 shapes the lists make its greedy sequence 3x faster). A problem solved on its own
    sets reads the members of the sets holding the chosen item instead (each neighbour once per set
    shared), which costs less than making the lists for a few greedy runs.
    """
    view = problem.conflict_view
    blocked = _neighbours_of(view.sets, reused=view.items.size < view.sets.n_items)
    room = np.inf if problem.cap is None else problem.cap
    n_items = order.size
    outer = view.items[order]
    place_of = np.full(view.sets.n_items, n_items, dtype=np.int64)  # items of no place: one spare entry
    place_of[outer] = np.arange(n_items)
    open_places = np.ones(n_items + 1, dtype=bool)
    shapes = counts[order]
    chosen: list[int] = []
    place = 0
    while place < n_items:
        place += int(np.argmax(open_places[place:n_items]))
        if not open_places[place]:
            break
        if shapes[place] <= room:
            chosen.append(int(order[place]))
            room -= shapes[place]
            open_places[place_of[blocked(outer[place])]] = False
        place += 1
    return tuple(chosen)


def _neighbours_of(sets: ConflictSets, reused: bool) -> Callable[[int], np.ndarray]:
    """A function of an item giving the items it conflicts with (itself included; repeated when read
    from the sets), from the sets' neighbour lists when they exist or ``reused`` says they will pay.
    ``sets`` are a `PackingProblem.conflict_view`'s."""
    if reused or sets.has_neighbours:
        starts, neighbours = sets.neighbours
        return lambda item: neighbours[starts[item] : starts[item + 1]]
    set_starts, members = sets.starts, sets.members
    holder_starts, holder_sets = sets.holders

    def members_of_holders(item: int) -> np.ndarray:
        held = holder_sets[holder_starts[item] : holder_starts[item + 1]]
        sizes = set_starts[held + 1] - set_starts[held]
        first = np.repeat(set_starts[held] - np.cumsum(sizes) + sizes, sizes)
        return members[first + np.arange(first.size)]

    return members_of_holders


class GreedySolver:
    """Algorithm 2 (sec. 4.5.2): strict greedy set packing with symmetry pairs as single items.

    Examples
    --------
    >>> import numpy as np
    >>> from packing import problem_from_incidence
    >>> problem = problem_from_incidence(np.array([[1, 1, 0], [0, 1, 1], [0, 0, 1]]), [0.5, 0.9, 0.4])
    >>> GreedySolver().solve(problem).items  # the heaviest item first: it blocks both others
    (1,)
    """

    name: ClassVar[str] = "greedy"
    capabilities: ClassVar[Capabilities] = Capabilities(exact=False, time_limit=False)

    @classmethod
    def availability(cls) -> Availability:
        """Always available: numpy only."""
        return Availability.available(distribution_version(PROJECT_DISTRIBUTION))

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Result:
        """Run Algorithm 2 to completion (``time_limit`` and ``seed`` are accepted and unused)."""
        return self._run(problem, 0.0)

    def _run(self, problem: PackingProblem, overlap: float) -> Result:
        clock = Stopwatch()
        order = greedy_order(problem)
        build_time = clock.lap()
        items = greedy_items(problem, overlap, order)
        message = f"overlap_allowed={overlap:g}" if overlap else ""
        return Result(items, Termination.COMPLETED, None, build_time, clock.lap(), message=message)


class GreedyOverlapSolver(GreedySolver):
    """Algorithm 2 with an allowed overlap fraction (sec. 4.5.2, "a small percentage of overlap").

    Its expressions may violate eq. 3b by design: it declares the fraction as ``capabilities.max_overlap``
    (per instance), results are verified with that allowance and no other, and the solution's ``message``
    carries ``overlap_allowed=<f>`` for the records.

    Parameters
    ----------
    overlap : float in [0, 1)
        An item may join the expression while at most this fraction of its active vertices is already
        active there.
    """

    name: ClassVar[str] = "greedy-overlap"
    capabilities: Capabilities = Capabilities(exact=False, time_limit=False, max_overlap=0.1)
    settings: ClassVar[tuple[Setting, ...]] = (
        Setting(
            "overlap",
            float,
            0.1,
            "share of an item's active vertices allowed to overlap",
            low=0,
            high=1,
            high_open=True,
        ),
    )

    def __init__(self, overlap: float = 0.1) -> None:
        self.overlap = float(checked_settings(self, {"overlap": overlap})["overlap"])
        self.capabilities = replace(type(self).capabilities, max_overlap=self.overlap)

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Result:
        """Run Algorithm 2 with the allowed overlap to completion."""
        return self._run(problem, self.overlap)
