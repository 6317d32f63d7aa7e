"""OR-Tools CP-SAT (plugin ``cpsat``): one ``AddAtMostOne`` per presolved conflict set, integer weights."""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from packing import PackingProblem, Termination
from solvers._base import Availability, Capabilities, Stopwatch, distribution_version, package_availability
from solvers._exact import BackendResult, ExactSolverBase
from solvers._model import CliqueModel

#: Total of the scaled integer weights. CP-SAT needs integer coefficients; scaling the weights so that
#: they sum to 2**50 keeps every weight to about 1e-15 relative (far finer than the tie-break
#: perturbation of `packing`), while the objective stays far below CP-SAT's int64 range.
OBJECTIVE_SCALE_TOTAL = 2.0**50


def integer_weights(weights: np.ndarray) -> tuple[np.ndarray, float]:
    """Weights scaled and rounded to int64, and the scale (integer = round(weight * scale)).

    Rounding moves each weight by at most ``0.5 / scale``, so an objective moves by at most
    ``I / (2 * scale)``: about ``I * 4e-16`` of the total weight. Two packings whose true objectives
    differ by more than that keep their order.
    """
    total = float(np.abs(weights).sum())
    scale = OBJECTIVE_SCALE_TOTAL / total if total > 0 else 1.0
    return np.rint(weights * scale).astype(np.int64), scale


def cpsat_parameters(solver, time_limit: float | None, seed: int, workers: int) -> None:
    """Deterministic exact CP-SAT settings: gaps 0, fixed seed and worker count, native time limit."""
    parameters = solver.parameters
    parameters.num_workers = workers
    parameters.random_seed = int(seed)
    parameters.relative_gap_limit = 0.0
    parameters.absolute_gap_limit = 0.0
    parameters.log_search_progress = False
    if time_limit is not None:
        parameters.max_time_in_seconds = float(time_limit)


class CpSatSolver(ExactSolverBase):
    """Eq. 3 as a CP-SAT model: a Boolean per item, ``AddAtMostOne`` per clique, a linear cap row.

    Parameters
    ----------
    workers : int
        CP-SAT search workers. One (the default) is deterministic for a given seed; more may be faster
        on hard instances but can return a different optimum among exact ties.
    """

    name: ClassVar[str] = "cpsat"
    capabilities: ClassVar[Capabilities] = Capabilities(exact=True, time_limit=True)

    def __init__(self, workers: int = 1) -> None:
        if not isinstance(workers, int) or workers < 1:
            raise ValueError(f"cpsat: workers must be a positive integer, got {workers!r}")
        self.workers = workers

    @classmethod
    def availability(cls) -> Availability:
        """Available when the ``ortools`` distribution is installed."""
        return package_availability("ortools", hint="pip install ortools")

    def _solve_model(
        self, problem: PackingProblem, model: CliqueModel, time_limit: float | None, seed: int
    ) -> BackendResult:
        from ortools.sat.python import cp_model

        clock = Stopwatch()
        scaled, scale = integer_weights(model.weights)
        cp = cp_model.CpModel()
        chosen = [cp.new_bool_var(f"x{i}") for i in range(model.n_items)]
        for r in range(model.n_rows):
            cp.add_at_most_one(chosen[i] for i in model.row(r).tolist())
        if model.cap is not None:
            cp.add(cp_model.LinearExpr.weighted_sum(chosen, model.shape_counts.tolist()) <= model.cap)
        cp.maximize(cp_model.LinearExpr.weighted_sum(chosen, scaled.tolist()))
        solver = cp_model.CpSolver()
        cpsat_parameters(solver, time_limit, seed, self.workers)
        build_time = clock.lap()
        status = solver.solve(cp)
        solve_time = clock.lap()
        version = f"ortools {distribution_version('ortools')}"
        if status not in (cp_model.OPTIMAL, cp_model.FEASIBLE, cp_model.UNKNOWN):
            message = f"CP-SAT stopped with status {solver.status_name(status)}"
            return BackendResult((), Termination.ERROR, None, build_time, solve_time, version, message)
        items: tuple[int, ...] = ()
        if status in (cp_model.OPTIMAL, cp_model.FEASIBLE):
            values = np.asarray(list(solver.response_proto.solution))[: model.n_items]
            items = tuple(np.flatnonzero(values).tolist())
        # The bound is on the scaled integers; add the worst-case rounding so it stays a true bound.
        bound = (solver.best_objective_bound + 0.5 * model.n_items) / scale
        termination = Termination.OPTIMAL if status == cp_model.OPTIMAL else Termination.TIME_LIMIT
        return BackendResult(items, termination, bound, build_time, solve_time, version)
