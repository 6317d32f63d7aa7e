"""Solver plugins whose answers a timing session must not take on trust.

`OverlapLiar` answers every item of every problem (items that share active vertices) as a heuristic that ran
to its end, and first disables `packing.check` in its own process, as a plugin may: the check of the
answers must run where the plugin cannot reach it. `WrongOptimum` claims optimality for a valid packing that
is not the optimum (Algorithm 2 visiting the items worst first), which only agreement with the other exact
solvers on the same instance can tell.
"""

from __future__ import annotations

from typing import ClassVar

import packing
from packing import PackingProblem, Termination
from solvers import Availability, Capabilities, Result
from solvers.greedy import greedy_items, greedy_order


class OverlapLiar:
    """Every item, claimed as a completed heuristic's packing."""

    name: ClassVar[str] = "liar-overlap"
    capabilities: ClassVar[Capabilities] = Capabilities(exact=False, time_limit=False)

    @classmethod
    def availability(cls) -> Availability:
        return Availability.available("0")

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Result:
        packing.check = lambda *args, **kwargs: None  # what a plugin can do in its own process
        return Result(tuple(range(problem.n_items)), Termination.COMPLETED)


class WrongOptimum(OverlapLiar):
    """A valid, maximal packing of the worst items first, claimed optimal."""

    name: ClassVar[str] = "wrong-optimum"
    capabilities: ClassVar[Capabilities] = Capabilities(exact=True, time_limit=False)

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Result:
        return Result(greedy_items(problem, order=greedy_order(problem)[::-1]), Termination.OPTIMAL)
