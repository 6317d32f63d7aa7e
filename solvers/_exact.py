"""The base of exact plugins: a plugin solves the presolved `CliqueModel`, this base does the rest.

An exact plugin implements ``solve_model(model, *, time_limit, seed) -> Result`` on the `CliqueModel`
(arrays of eq. 3 after presolve). `ExactSolver.solve` answers the empty problem, applies the exact
reductions of `solvers._reduce` (dominated items out, conflict-free items in: the optimal packings stay
exactly the same) so that the backend sees only the kernel, maps the kernel's items back to the problem's,
times the array preparation and, when a time limit stops a backend with no incumbent or one worse than
Algorithm 2's packing, answers that packing instead (valid by construction), so a time-limited solve
always has an incumbent at least as good as the greedy one. The framework (`solvers.load`) then checks and
normalises the answer as for any plugin.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import replace
from typing import TYPE_CHECKING, ClassVar

from packing import Termination
from solvers._base import Capabilities, Result, Stopwatch, trivial_bound
from solvers._model import CliqueModel
from solvers._reduce import reduce_problem

if TYPE_CHECKING:
    from packing import PackingProblem


class ExactSolver:
    """A `Solver` whose subclasses solve eq. 3 on the presolved model (MILP, CP-SAT, ...).

    Subclasses set ``name``, ``capabilities`` and ``availability`` as any plugin, and implement
    `solve_model`. ``reduces`` (default True) applies `solvers._reduce.reduce_problem` first, so
    ``solve_model`` gets the model of the kernel; a plugin that must see the problem as given (the
    paper's per-vertex formulation, ``naive-pulp-cbc``) sets it False and overrides `solve_problem`.

    Examples
    --------
    ``examples/solver_plugin/example_scipy_milp.py`` is a complete plugin on SciPy's MILP interface:
    ``solve_model`` calls ``scipy.optimize.milp(-model.weights, integrality=1, bounds=(0, 1),
    constraints=model.constraint())`` and returns ``Result(items, termination, bound=...)``.
    """

    name: ClassVar[str]
    capabilities: ClassVar[Capabilities]
    reduces: ClassVar[bool] = True

    def solve_model(self, model: CliqueModel, *, time_limit: float | None, seed: int) -> Result:
        """Solve ``max w.x`` over the model's clique rows and cap row, x binary (eq. 3 after presolve).

        Parameters
        ----------
        model : CliqueModel
        time_limit : float or None
            Seconds for the backend's search.
        seed : int
            The backend's random seed.

        Returns
        -------
        Result
            Items as indices of ``model``; OPTIMAL (MIP gap 0) or TIME_LIMIT with the incumbent and the
            proved bound, or ERROR with the backend's message.
        """
        raise NotImplementedError(f"{type(self).__name__} must implement solve_model")

    def solve_problem(
        self, problem: PackingProblem, model: CliqueModel, *, time_limit: float | None, seed: int
    ) -> Result:
        """The backend's answer for ``problem``, presolved as ``model`` (by default `solve_model`'s)."""
        return self.solve_model(model, time_limit=time_limit, seed=seed)

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Result:
        """Solve eq. 3 to proven optimality (MIP gap 0) or until ``time_limit`` (build time not included).

        Returns
        -------
        Result
            Items of ``problem``; at a time limit the better of the backend's incumbent and Algorithm 2's
            packing, with a bound no lower than it.
        """
        clock = Stopwatch()
        if problem.n_items == 0:
            return Result((), Termination.OPTIMAL, 0.0, build_time=0.0, solve_time=0.0)
        cap_binds = problem.cap is not None and problem.cap < int(problem.item_shape_counts.sum())
        reduction = reduce_problem(problem, cap_binds) if self.reduces else None
        model = CliqueModel.from_problem(problem) if reduction is None else reduction.model
        prepare_time = clock.lap()
        if model.n_items == 0:  # the reductions decided every item
            result = Result((), Termination.OPTIMAL, 0.0, build_time=0.0, solve_time=0.0)
        else:
            result = self.solve_problem(problem, model, time_limit=time_limit, seed=seed)
        items, message, bound = _model_items(result.items, model.n_items), result.message, result.bound
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
            if bound is None or bound < problem.objective(items) - 1e-9 * max(1.0, abs(bound)):
                bound = trivial_bound(problem)  # the backend proved nothing usable before it stopped
        return replace(
            result,
            items=items,
            bound=bound,
            message=message,
            build_time=prepare_time + (result.build_time or 0.0),
            solve_time=result.solve_time if result.solve_time is not None else clock.lap(),
        )


def _model_items(items: Iterable[int], n_items: int) -> tuple[int, ...]:
    """The backend's items as Python ints, each an item of the model it solved, none twice."""
    chosen = [int(i) for i in items]
    if any(not 0 <= i < n_items for i in chosen) or len(set(chosen)) != len(chosen):
        raise ValueError(f"the backend answered items {chosen} for a model of {n_items} items")
    return tuple(chosen)
