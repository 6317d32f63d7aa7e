"""Solver plugins that lie, for the certificate tests (`test_certificate.py`) and the checks of a cell
(`test_cell_outcomes.py`).

The packings of the proof liars are valid and maximal (Algorithm 2 visiting the items in reverse order), so
the harness's own checks pass; only their claims are false. `InfeasibleLiar` answers every problem with
nothing, declared infeasible, which no packing problem is.
"""

from __future__ import annotations

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
