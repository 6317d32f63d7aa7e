"""Solver plugins that fail, each in its own way, for the failure tests of ``harness pack``."""

from __future__ import annotations

import os
import sys
import threading
from typing import ClassVar

from packing import PackingProblem, Termination
from solvers import Availability, Capabilities, Result
from solvers.greedy import GreedySolver


class Raising:
    """Raises an exception from its backend."""

    name: ClassVar[str] = "fail-raise"
    capabilities: ClassVar[Capabilities] = Capabilities(exact=False, time_limit=False)

    @classmethod
    def availability(cls) -> Availability:
        return Availability.available("0")

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Result:
        raise RuntimeError("the backend lost its licence")


class OutOfRange(Raising):
    """Answers an item the problem does not have."""

    name: ClassVar[str] = "fail-range"

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Result:
        return Result((0, problem.n_items + 5), Termination.COMPLETED)


class Duplicate(Raising):
    """Answers the same item twice."""

    name: ClassVar[str] = "fail-twice"

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Result:
        return Result((0, 0), Termination.COMPLETED)


class Infeasible(Raising):
    """Claims that no expression exists."""

    name: ClassVar[str] = "fail-infeasible"

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Result:
        return Result((), Termination.INFEASIBLE)


class Exiting(Raising):
    """Ends the interpreter with ``sys.exit``."""

    name: ClassVar[str] = "fail-exit"

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Result:
        sys.exit(3)


class Aborting(Raising):
    """Crashes the process (``os.abort``, as a segfaulting backend library would)."""

    name: ClassVar[str] = "fail-abort"

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Result:
        os.abort()


class SecondFails(Raising):
    """Packs the first expression with its first item, then raises."""

    name: ClassVar[str] = "fail-second"

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Result:
        if problem.meta.get("expression") == 1:
            return Result((0,), Termination.COMPLETED)
        raise RuntimeError("out of memory")


class Stalling(Raising):
    """Claims a native time limit, then never answers (it ignores the limit), the warm-up solve included."""

    name: ClassVar[str] = "stall"
    capabilities: ClassVar[Capabilities] = Capabilities(exact=False, time_limit=True)

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Result:
        threading.Event().wait()
        raise AssertionError("unreachable")


class StallingSecond(Stalling):
    """Packs the first expression as greedy does (Algorithm 2), then never answers."""

    name: ClassVar[str] = "stall-second"

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Result:
        if problem.meta.get("expression", 1) == 1:
            return GreedySolver().solve(problem)
        return super().solve(problem, time_limit=time_limit, seed=seed)
