"""Solver plugins that lie or misbehave, for the certificate tests (`test_certificate.py`) and the
outcomes of a cell (`test_cell_outcomes.py`).

The packings of the proof liars are valid and maximal (Algorithm 2 visiting the items in reverse order), so
the harness's own checks pass; only their claims are false. `InfeasibleLiar` answers every problem with
nothing, declared infeasible, which no packing problem is. `StuckSolver` never answers and
`CrashingSolver` ends its process with SIGSEGV, on every problem (their warm-up solve included).
"""

from __future__ import annotations

import os
import resource
import signal
import time
from typing import ClassVar

from packing import PackingProblem, Termination
from solvers import Availability, Capabilities, Result
from solvers.greedy import greedy_items, greedy_order


def _worst_first(problem: PackingProblem) -> tuple[int, ...]:
    return greedy_items(problem, order=greedy_order(problem)[::-1])


class OptimalLiar:
    """Claims OPTIMAL for a packing built from the worst items first."""

    name: ClassVar[str] = "liar-optimal"
    capabilities: ClassVar[Capabilities] = Capabilities(exact=True, time_limit=True)

    @classmethod
    def availability(cls) -> Availability:
        return Availability.available("0")

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Result:
        return Result(_worst_first(problem), Termination.OPTIMAL)


class BoundLiar(OptimalLiar):
    """Stops at a "time limit" with the same packing and claims its objective as the proved bound."""

    name: ClassVar[str] = "liar-bound"

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Result:
        items = _worst_first(problem)
        return Result(items, Termination.TIME_LIMIT, bound=problem.objective(items))


class InfeasibleLiar(OptimalLiar):
    """Declares every problem infeasible and chooses nothing (choosing nothing is always feasible)."""

    name: ClassVar[str] = "liar-infeasible"

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Result:
        return Result((), Termination.INFEASIBLE)


class StuckSolver(OptimalLiar):
    """Sleeps an hour on every problem."""

    name: ClassVar[str] = "stuck"

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Result:
        time.sleep(3600)
        return Result((), Termination.ERROR)


class CrashingSolver(OptimalLiar):
    """Ends its own process with SIGSEGV on every problem, as a solver library that segfaults does."""

    name: ClassVar[str] = "crashing"

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Result:
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))  # no core file wherever the test runs
        os.kill(os.getpid(), signal.SIGSEGV)
        time.sleep(3600)  # the signal ends the process first
        return Result((), Termination.ERROR)
