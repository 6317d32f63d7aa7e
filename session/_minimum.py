"""``harness pack --minimum``: the fewest expressions that cover every shape, in importance order.

Beyond the paper (Algorithm 1 does not minimise the count): the minimum is a colouring of the item
conflict graph (`solvers.minimum_expressions`), proved by its lower bound (the largest conflict set, the
cap bound, or CP-SAT's bound), and the sequence then gives each expression in turn the most importance
(eq. 3a) the minimum count allows (`solvers.ordered_minimum_sequence`). When the proof does not finish
within the time limit, the cover found is used and what was proved is said: the count lies between the
lower bound and the cover's size.

The cover and its ordering are solved in a worker process (`solvers.worker`), as every solve of ``harness
pack`` is (`harness.IsolatedSolver`): a backend that crashes or exits is one `SolverFailure` line, and Ctrl-C
stops the worker and reaches the packing's clean-up.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from harness import SolverFailure, last_line

if TYPE_CHECKING:
    from packing import Analysis, Expression, PackingProblem
    from solvers import OrderedSequence

#: Seconds for the proof (and each ordered step) when no ``--time-limit`` is given.
DEFAULT_TIME_LIMIT = 60.0

#: The function the worker process solves with (``"module:function"``, `ordered_cover`).
SOLVE_IN_WORKER = "session._minimum:ordered_cover"


@dataclass(frozen=True)
class MinimumResult:
    """The ordered minimum sequence and what was proved about its count.

    Attributes
    ----------
    expressions : list of packing.Expression
        In sequence order.
    count : int
        Expressions in the cover used.
    lower_bound : int
        Proved lower bound on the fewest expressions.
    time_limit : float
        Seconds the proof and each step were given.
    """

    expressions: list[Expression]
    count: int
    lower_bound: int
    time_limit: float

    @property
    def proven(self) -> bool:
        """Whether ``count`` is proved to be the fewest."""
        return self.count == self.lower_bound

    def summary(self) -> dict[str, int | float | bool]:
        """The ``sequence.minimum`` entry of ``expressions.json``."""
        return {
            "count": self.count,
            "lower_bound": self.lower_bound,
            "proven": self.proven,
            "time_limit": self.time_limit,
        }

    def message(self) -> str:
        """One line: the count and its proof, or the bounds when the proof did not finish."""
        if self.proven:
            return (
                f"minimum: {self.count} expressions cover every shape, proven "
                f"(lower bound {self.lower_bound})"
            )
        return (
            f"--minimum not proven within {self.time_limit:g}s: the fewest expressions is at least "
            f"{self.lower_bound} and at most {self.count}; the {self.count} found are written "
            "(a longer --time-limit may prove or lower it)"
        )


def minimum_sequence(analysis: Analysis, *, time_limit: float | None, seed: int) -> MinimumResult:
    """The ordered minimum sequence of every packable shape of ``analysis``.

    Parameters
    ----------
    analysis : packing.Analysis
        Its problem over every item, weighted for the first expression (eq. 4), is covered.
    time_limit : float, optional
        Seconds for the proof and for each ordered step; default `DEFAULT_TIME_LIMIT`.
    seed : int

    Raises
    ------
    SolverFailure
        When the solve failed in the worker (it raised, e.g. for an item with more shapes than the cap
        allows, exited or crashed).
    """
    import packing
    import solvers

    limit = DEFAULT_TIME_LIMIT if time_limit is None else float(time_limit)
    problem = analysis.problem
    try:
        ordered: OrderedSequence = solvers.worker("pack-minimum").call(  # type: ignore[assignment]
            SOLVE_IN_WORKER, problem, limit, seed
        )
    except solvers.WorkerDied as error:
        raise SolverFailure(f"solver cpsat failed on --minimum: its process died ({error.exit})") from None
    except solvers.WorkerError as error:
        raise SolverFailure(f"solver cpsat failed on --minimum: {last_line(str(error))}") from None
    minimum = ordered.minimum
    expressions = []
    for index, (items, termination) in enumerate(
        zip(ordered.expressions, ordered.terminations, strict=True), start=1
    ):
        objective = float(problem.unperturbed_objective(items))
        solution = packing.Solution(
            items=tuple(items),
            shapes=tuple(problem.shapes_of(items)),
            objective=objective,
            bound=None,
            termination=termination,
            solve_time=ordered.solve_time if index == 1 else 0.0,
            backend="minimum",
            version=minimum.version,
        )
        expressions.append(
            packing.Expression(
                index=index,
                shapes=solution.shapes,
                items=tuple(problem.item_label(item) for item in items),
                objective=objective,
                solution=solution,
                presolve_time=0.0,
                n_items=problem.n_items,
                vertex_rows=problem.n_vertex_rows,
                clique_rows=len(problem.cliques),
            )
        )
    return MinimumResult(expressions, minimum.count, minimum.lower_bound, limit)


def ordered_cover(problem: PackingProblem, time_limit: float, seed: int) -> OrderedSequence:
    """The fewest expressions covering ``problem`` (`solvers.minimum_expressions`, CP-SAT) in importance
    order (`solvers.ordered_minimum_sequence`); run in the worker process."""
    import solvers

    minimum = solvers.minimum_expressions(problem, solver="cpsat", time_limit=time_limit, seed=seed)
    return solvers.ordered_minimum_sequence(problem, time_limit=time_limit, seed=seed, minimum=minimum)
