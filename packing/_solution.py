"""What a solver returns for one packing problem: chosen items, objective, bound and why it stopped."""

from __future__ import annotations

import enum
from dataclasses import dataclass


class Termination(enum.StrEnum):
    """Why a solver stopped (kept apart from what the solution is, as in Pyomo)."""

    OPTIMAL = "optimal"  #: proved optimal
    COMPLETED = "completed"  #: a heuristic ran to its end (no optimality claim)
    TIME_LIMIT = "time_limit"  #: stopped by the time limit; ``items`` is the incumbent, if any
    INFEASIBLE = "infeasible"  #: proved that no solution exists
    ERROR = "error"  #: the backend failed; ``message`` says how


class SolutionStatus(enum.StrEnum):
    """What the returned items are."""

    OPTIMAL = "optimal"
    FEASIBLE = "feasible"
    NONE = "none"


@dataclass(frozen=True)
class Solution:
    """A solver's answer to one `PackingProblem`.

    Attributes
    ----------
    items : tuple of int
        Chosen item indices, ascending.
    shapes : tuple of str
        Names of the blendshapes in the chosen items.
    objective : float
        Importance sum of the chosen items (eq. 3a), without the tie-break perturbation of the weights.
    bound : float or None
        Best proved upper bound on the objective (equals ``objective`` when optimal); None for heuristics.
    termination : Termination
        Why the solver stopped.
    build_time, solve_time : float
        Seconds spent building the backend model and solving it.
    backend : str
        Solver plugin name; ``version`` the backend library version.
    message : str
        Details, e.g. the error text.
    """

    items: tuple[int, ...]
    shapes: tuple[str, ...]
    objective: float
    bound: float | None
    termination: Termination
    build_time: float = 0.0
    solve_time: float = 0.0
    backend: str = ""
    version: str = ""
    message: str = ""

    @property
    def status(self) -> SolutionStatus:
        """Optimal, feasible or none, derived from the termination and the items."""
        if self.termination is Termination.OPTIMAL:
            return SolutionStatus.OPTIMAL
        if self.termination in (Termination.INFEASIBLE, Termination.ERROR):
            return SolutionStatus.NONE
        return (
            SolutionStatus.FEASIBLE
            if self.items or self.termination is Termination.COMPLETED
            else SolutionStatus.NONE
        )
