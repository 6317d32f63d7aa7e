"""Solver plugins that misbehave on demand, for the end-to-end `harness compare` test.

Both run Algorithm 2 (`solvers.greedy.GreedySolver`). With ``PROBE_SOLVERS=degraded`` in the environment
(which the harness's worker processes inherit) ``probe-slow`` sleeps before answering and ``probe-worse``
drops the last item of every answer that has more than one; otherwise both answer exactly as greedy.
``probe-spinner`` computes for `BASE_SPIN` seconds of its thread's CPU time per solve, twice that with
``PROBE_SOLVERS=doubled``: work that a loaded machine slows as it slows a solver, unlike a sleep.
"""

from __future__ import annotations

import dataclasses
import os
import time
from typing import ClassVar

from packing import PackingProblem, Solution
from solvers.greedy import GreedySolver

#: Environment variable that switches the probes from plain to degraded.
MODE = "PROBE_SOLVERS"
SLEEP = 0.05
BASE_SPIN = 0.004


def _degraded() -> bool:
    return os.environ.get(MODE) == "degraded"


class SlowedGreedy(GreedySolver):
    """Greedy that sleeps ``SLEEP`` seconds per solve when degraded (and reports it as solve time)."""

    name: ClassVar[str] = "probe-slow"

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Solution:
        started = time.perf_counter()
        if _degraded():
            time.sleep(SLEEP)
        solution = super().solve(problem, time_limit=time_limit, seed=seed)
        return dataclasses.replace(solution, solve_time=time.perf_counter() - started - solution.build_time)


class WorseGreedy(GreedySolver):
    """Greedy that leaves out one item of each multi-item answer when degraded."""

    name: ClassVar[str] = "probe-worse"

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Solution:
        solution = super().solve(problem, time_limit=time_limit, seed=seed)
        if not _degraded() or len(solution.items) < 2:
            return solution
        items = tuple(sorted(solution.items))[:-1]
        return dataclasses.replace(
            solution, items=items, shapes=problem.shapes_of(items), objective=problem.objective(items)
        )


class SpinningGreedy(GreedySolver):
    """Greedy that computes for `BASE_SPIN` seconds of CPU time per solve, or twice as long when doubled."""

    name: ClassVar[str] = "probe-spinner"

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Solution:
        started = time.perf_counter()
        until = time.thread_time() + BASE_SPIN * (2 if os.environ.get(MODE) == "doubled" else 1)
        while time.thread_time() < until:
            pass
        solution = super().solve(problem, time_limit=time_limit, seed=seed)
        return dataclasses.replace(solution, solve_time=time.perf_counter() - started - solution.build_time)
