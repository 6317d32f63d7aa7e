"""Solver plugins that cheat in their own process, for the harness's own check (`test_parent_check.py`).

`CheckBreaker` turns `packing.check` (and the replay check) into no-ops in the process it solves in, then
answers every problem with all its items, which overlap: a worker's own check then passes it. `ForkingSolver`
forks, and both processes answer; the child stays behind, holding the worker's streams.
"""

from __future__ import annotations

import os
import time
from typing import ClassVar

import packing
from packing import PackingProblem, Termination
from solvers import Availability, Capabilities, Result
from solvers.greedy import greedy_items


def _nothing(*arguments: object, **keywords: object) -> None:
    return None


class CheckBreaker:
    """Disables the checker where it runs and claims every item, optimal."""

    name: ClassVar[str] = "check-breaker"
    capabilities: ClassVar[Capabilities] = Capabilities(exact=True, time_limit=False)

    @classmethod
    def availability(cls) -> Availability:
        return Availability.available("0")

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Result:
        import harness._replay

        packing.check = _nothing
        harness._replay.check = _nothing
        return Result(tuple(range(problem.n_items)), Termination.OPTIMAL)


class ForkingSolver:
    """Forks on every solve: the parent answers greedy's items, the child answers too and then lingers."""

    name: ClassVar[str] = "forking"
    capabilities: ClassVar[Capabilities] = Capabilities(exact=False, time_limit=False)

    @classmethod
    def availability(cls) -> Availability:
        return Availability.available("0")

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Result:
        if os.fork() == 0:
            time.sleep(30)
        return Result(greedy_items(problem), Termination.COMPLETED)
