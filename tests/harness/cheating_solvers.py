"""Solver plugins that cheat in their own process, for the harness's own check (`test_parent_check.py`).

`CheckBreaker` turns the pipeline's check (`packing.Pipeline.check`, which the replay check calls too) into a
no-op in the process it solves in, then answers every problem with all its items, which overlap: a worker's
own check then passes it. `ForkingSolver` forks, and both processes answer; the child stays behind, holding
the worker's streams. `SilentAvailability` never says whether it is available, `SleepingSolver` ignores its
time limit and `ExitingSolver` calls ``sys.exit(0)``.
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
        packing.Pipeline.check = _nothing
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


class SilentAvailability(ForkingSolver):
    """Never answers whether it is available (its ``availability()`` sleeps for a minute)."""

    name: ClassVar[str] = "silent"

    @classmethod
    def availability(cls) -> Availability:
        time.sleep(60)
        return Availability.available("0")


class SleepingSolver(ForkingSolver):
    """Ignores its time limit: sleeps for a minute on every problem."""

    name: ClassVar[str] = "sleeping"
    capabilities: ClassVar[Capabilities] = Capabilities(exact=False, time_limit=True)

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Result:
        time.sleep(60)
        return Result(greedy_items(problem), Termination.COMPLETED)


class ExitingSolver(ForkingSolver):
    """Ends its process with ``sys.exit(0)`` on every problem."""

    name: ClassVar[str] = "exiting"

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Result:
        import sys

        sys.exit(0)
