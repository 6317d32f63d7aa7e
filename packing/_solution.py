"""What a solver returns for one packing problem (chosen items, objective, bound and why it stopped), and
the expression of the sequence (Algorithm 1) made from it."""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Any

from packing._deferred import DeferredField, computed_state


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
    cpu_time : float or None
        CPU seconds of the whole solve call (`solvers.cpu_seconds`: every thread of the process, the
        child processes it waited for and its calls to worker processes); None where not measured.
    backend : str
        Solver plugin name; ``version`` the backend library version.
    message : str
        Details, e.g. the error text.
    fallback : str
        The method that supplied ``items`` instead of the backend (``"greedy"``: Algorithm 2's packing,
        answered when a time limit stopped an exact backend with no incumbent or a worse one); empty when
        the items are the backend's own.
    """

    items: tuple[int, ...]
    shapes: tuple[str, ...]
    objective: float
    bound: float | None
    termination: Termination
    build_time: float = 0.0
    solve_time: float = 0.0
    cpu_time: float | None = None
    backend: str = ""
    version: str = ""
    message: str = ""
    fallback: str = ""

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


#: The timed steps of one expression, as `Expression` attributes (and records columns of the same names):
#: deriving its problem from the analysis (presolve, sec. 6), building the solver's model, solving eq. 3, and
#: the second pass of sec. 6. Their sum is the expression's share of its sequence's time.
EXPRESSION_TIMES: tuple[str, ...] = ("presolve_time", "build_time", "solve_time", "extra_time")


@dataclass(frozen=True)
class Expression:
    """One reference expression of the sequence (Carrigan et al. 2020, Algorithm 1): the solver's `Solution`
    of its problem, with what the sequence derived from it.

    The solution's attributes read through the expression (``expression.bound`` is
    ``expression.solution.bound``), except those the sequence derives again from its own problem:
    ``shapes``, ``items`` and ``objective``.

    Attributes
    ----------
    index : int
        1-based position in the sequence.
    shapes : tuple of str
        Blendshapes this expression is the primary example of (both shapes of a pair).
    items : tuple of str
        Labels of the chosen items (``a+b`` for a pair).
    objective : float
        Eq. 3a: the importance (eq. 4) of the chosen shapes, without the tie-break perturbation, evaluated
        on the expression's problem (not taken from the solver).
    solution : Solution
        The solver's answer to the expression's problem (its ``items`` index that problem's items).
    presolve_time : float
        Seconds to derive this expression's problem from the analysis (restrict and presolve).
    n_items : int
        Items available to this expression.
    vertex_rows, clique_rows : int
        Conflict rows before presolve (one per vertex active in an available item, eq. 3b) and after
        (maximal conflict sets). ``clique_rows`` may be given as a `packing._deferred.Deferred`: the
        sequence does so when the solver did not need the maximal sets (`PackingProblem.deferred_n_cliques`),
        and they are derived on first read.
    extra_examples : tuple of str
        Shapes already used earlier and added again by the second pass of sec. 6.
    extra_time : float
        Seconds spent by the solver choosing the extra examples.
    """

    index: int
    shapes: tuple[str, ...]
    items: tuple[str, ...]
    objective: float
    solution: Solution
    presolve_time: float
    n_items: int
    vertex_rows: int
    clique_rows: int = DeferredField()  # type: ignore[assignment]
    extra_examples: tuple[str, ...] = ()
    extra_time: float = 0.0

    def __getstate__(self) -> dict[str, Any]:
        """The instance dictionary with ``clique_rows`` computed (a deferred value does not pickle)."""
        return computed_state(self)

    @property
    def bound(self) -> float | None:
        """The solver's best bound on the objective (None for heuristics)."""
        return self.solution.bound

    @property
    def termination(self) -> Termination:
        """Why the solver stopped."""
        return self.solution.termination

    @property
    def status(self) -> SolutionStatus:
        """Optimal, feasible or none (`Solution.status`)."""
        return self.solution.status

    @property
    def build_time(self) -> float:
        """Seconds the solver spent building its backend model."""
        return self.solution.build_time

    @property
    def solve_time(self) -> float:
        """Seconds the solver spent solving."""
        return self.solution.solve_time

    @property
    def cpu_time(self) -> float | None:
        """CPU seconds of the solver's call (None where not measured)."""
        return self.solution.cpu_time

    @property
    def backend(self) -> str:
        """Solver plugin name."""
        return self.solution.backend

    @property
    def version(self) -> str:
        """Backend library version."""
        return self.solution.version

    @property
    def message(self) -> str:
        """The solver's message, if any."""
        return self.solution.message

    @property
    def fallback(self) -> str:
        """The method that supplied the items instead of the backend (`Solution.fallback`), if any."""
        return self.solution.fallback
