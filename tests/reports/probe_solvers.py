"""Solver plugins that misbehave on demand, for the end-to-end `harness compare` test.

Both run Algorithm 2 (`solvers.greedy.GreedySolver`). With ``PROBE_SOLVERS=degraded`` in the environment
(which the harness's worker processes inherit) ``probe-slow`` spends ``SPIN`` seconds of CPU before
answering (a few hundred times its solve: far beyond any machine's noise, and work that CPU time counts,
unlike a sleep) and ``probe-worse`` drops the last item of every answer that has more than one; otherwise
both answer exactly as greedy.
``probe-highs`` solves each problem with HiGHS twice, four times with ``PROBE_SOLVERS=doubled``: twice a real
solver's work, which the state of a run (caches, clock, neighbours) slows as it slows the exact solvers
the times are divided by, unlike a sleep or a spin loop (measured: a spin loop's ratio to them moved 1.46x
between two runs of the same code). It answers as a heuristic (``completed``), so it is no reference.
"""

from __future__ import annotations

import dataclasses
import os
import time
from typing import ClassVar

from packing import PackingProblem, Solution, Termination
from registry import Availability
from solvers import Capabilities, Result
from solvers.greedy import GreedySolver
from solvers.highs import HighsSolver

#: Environment variable that switches the probes from plain to degraded.
MODE = "PROBE_SOLVERS"
#: CPU seconds a degraded ``probe-slow`` spends per solve.
SPIN = 0.05


def _degraded() -> bool:
    return os.environ.get(MODE) == "degraded"


class SlowedGreedy(GreedySolver):
    """Greedy that spends ``SPIN`` CPU seconds per solve when degraded (and reports them as solve time)."""

    name: ClassVar[str] = "probe-slow"

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Solution:
        started = time.perf_counter()
        if _degraded():
            end = time.process_time() + SPIN
            while time.process_time() < end:
                pass
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


class DoublingHighs:
    """HiGHS on each problem, twice or (doubled) four times, answering as a heuristic."""

    name: ClassVar[str] = "probe-highs"
    capabilities = Capabilities(exact=False, time_limit=False)

    @classmethod
    def availability(cls) -> Availability:
        return HighsSolver.availability()

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Result:
        inner = HighsSolver()
        for _ in range(4 if os.environ.get(MODE) == "doubled" else 2):
            answer = inner.solve(problem, seed=seed)
        return Result(answer.items, Termination.COMPLETED)
