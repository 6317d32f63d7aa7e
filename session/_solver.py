"""The solver of ``harness pack``: in a worker process of its own (`harness.IsolatedSolver`), and a failure is
the packing's end.

A session must never come out short without saying why. `LoudSolver`, the outermost wrapper, turns every
failed answer (``Termination.ERROR``: a solver that raised, answered what the problem does not have, called
``sys.exit`` or lost its process), and a claim that an expression is infeasible (the empty expression always
is feasible), into a `harness.SolverFailure`: one line naming the solver, the expression and the reason, and
a non-zero exit of ``harness pack``.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING, Any

from harness import SolverFailure, last_line

if TYPE_CHECKING:
    from packing import PackingProblem, Solution


class LoudSolver:
    """The outermost solver of a packing: every failed answer raises `SolverFailure`.

    Parameters
    ----------
    inner : solver
        What the expression sequence calls (the isolated solver, behind a deadline or refinement).
    name : str
        The solver's name for the message (the user's ``--solver``).
    """

    def __init__(self, inner: Any, name: str) -> None:
        self.inner = inner
        self.name = name

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Solution:
        """The inner answer, unless it is a failure.

        Raises
        ------
        SolverFailure
            For ``Termination.ERROR`` or ``Termination.INFEASIBLE``.
        """
        from packing import Termination

        solution = self.inner.solve(problem, time_limit=time_limit, seed=seed)
        if solution.termination is Termination.ERROR:
            reason = last_line(solution.message) or "no message"
        elif solution.termination is Termination.INFEASIBLE:
            reason = "it claims the expression is infeasible, but an empty expression always is feasible"
        else:
            return solution
        expression = problem.meta.get("expression", "?")
        stage = " (extra examples)" if problem.meta.get("stage") == "extra_examples" else ""
        for prefix in (f"{solution.backend}: ", f"{self.name}: "):  # the plugin's name, said once
            reason = reason.removeprefix(prefix)
        reason = re.sub(r"^(?:\w+\.)+(?=\w+: )", "", reason)  # an exception's module path
        raise SolverFailure(f"solver {self.name} failed on expression {expression}{stage}: {reason}")
