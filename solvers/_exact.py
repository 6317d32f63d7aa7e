"""Shared driver of the exact backends: presolved arrays in, a checked `Solution` out.

Each exact plugin implements only ``_solve_model(model, time_limit, seed) -> BackendResult`` on the
`CliqueModel`; this driver validates the arguments, answers the empty problem, applies the exact reductions
of `solvers._reduce` (dominated items out, conflict-free items in: the optimal packings stay exactly the
same) so that the backend sees only the kernel, times the array preparation, turns backend exceptions into
``Termination.ERROR`` and, when a time limit stops a backend with no incumbent or one worse than Algorithm
2's packing, returns that packing instead (valid by construction), so a time-limited solve always has an
incumbent at least as good as the greedy one.
"""

from __future__ import annotations

import functools
import traceback
from dataclasses import dataclass
from typing import ClassVar

from packing import PackingProblem, Solution, Termination
from solvers._base import Capabilities, Stopwatch, check_solve_arguments, make_solution, trivial_bound
from solvers._model import CliqueModel
from solvers._reduce import reduce_problem


@dataclass(frozen=True)
class BackendResult:
    """What a backend reports on a `CliqueModel` (picklable, so isolated workers can return it).

    Attributes
    ----------
    items : tuple of int
        Chosen items (empty when none was found).
    termination : Termination
    bound : float or None
        Proved upper bound on eq. 3a, if the backend reports one.
    build_time, solve_time : float
        Seconds to build the backend's model and to solve it, measured where the backend runs.
    version : str
        Backend library (and binary) version that ran.
    message : str
    """

    items: tuple[int, ...]
    termination: Termination
    bound: float | None
    build_time: float
    solve_time: float
    version: str
    message: str = ""


@functools.cache
def _reported_version(solver: type) -> str:
    """The backend version a solver class reports by its availability (read once per process)."""
    return solver.availability().version


class ExactSolverBase:
    """`Solver` implementation shared by the MILP / CP-SAT plugins; subclasses provide `_solve_model`.

    ``reduces`` (default True) applies `solvers._reduce.reduce_problem` first: ``_solve_model`` then gets
    the model of the kernel (its items are ``Reduction.kept``) and must read the model, not the problem's
    items. A plugin that must see the problem as given (the paper's formulation, ``naive-pulp-cbc``) sets it
    False.
    """

    name: ClassVar[str]
    capabilities: ClassVar[Capabilities]
    reduces: ClassVar[bool] = True

    def _solve_model(
        self, problem: PackingProblem, model: CliqueModel, time_limit: float | None, seed: int
    ) -> BackendResult:
        raise NotImplementedError

    def _version(self) -> str:
        """Version string reported when the backend did not run (empty or failed solve)."""
        return _reported_version(type(self))

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Solution:
        """Solve eq. 3 on the presolved model to proven optimality (MIP gap 0) or until ``time_limit``.

        Parameters
        ----------
        problem : PackingProblem
        time_limit : float, optional
            Seconds for the backend's search (build time not included).
        seed : int
            Backend random seed; the same seed gives the same items.

        Returns
        -------
        Solution
            ``termination`` is OPTIMAL, TIME_LIMIT (with the incumbent and the proved bound), or ERROR
            with the backend's message.
        """
        check_solve_arguments(problem, time_limit, seed)
        clock = Stopwatch()
        if problem.n_items == 0:
            return make_solution(
                problem, (), termination=Termination.OPTIMAL, bound=0.0, build_time=0.0, solve_time=0.0,
                backend=self.name, version=self._version(),
            )  # fmt: skip
        cap_binds = problem.cap is not None and problem.cap < int(problem.item_shape_counts.sum())
        reduction = reduce_problem(problem, cap_binds) if self.reduces else None
        model = CliqueModel.from_problem(problem) if reduction is None else reduction.model
        prepare_time = clock.lap()
        try:
            if model.n_items == 0:  # the reductions decided every item
                result = BackendResult((), Termination.OPTIMAL, 0.0, 0.0, 0.0, self._version())
            else:
                result = self._solve_model(problem, model, time_limit, seed)
        except Exception as error:  # a failing backend is reported, never raised into the run
            detail = "".join(traceback.format_exception_only(error)).strip()
            return make_solution(
                problem, (), termination=Termination.ERROR, bound=None, build_time=prepare_time,
                solve_time=clock.lap(), backend=self.name, version=self._version(), message=detail,
            )  # fmt: skip
        items, message, bound = result.items, result.message, result.bound
        if reduction is not None:
            items = reduction.items(items)
            if bound is not None:
                bound += float(problem.weights[reduction.taken].sum())
        if result.termination is Termination.TIME_LIMIT:
            from solvers.greedy import greedy_items

            fallback = greedy_items(problem)
            if not items or problem.objective(fallback) > problem.objective(items):
                items = fallback
                message = (
                    message + "; " if message else ""
                ) + "incumbent at the time limit: Algorithm 2's packing"
        if result.termination is Termination.TIME_LIMIT and (
            bound is None or bound < problem.objective(items) - 1e-9 * max(1.0, abs(bound))
        ):
            bound = trivial_bound(problem)  # the backend proved nothing usable before it stopped
        return make_solution(
            problem,
            items,
            termination=result.termination,
            bound=bound,
            build_time=prepare_time + result.build_time,
            solve_time=result.solve_time,
            backend=self.name,
            version=result.version,
            message=message,
        )
