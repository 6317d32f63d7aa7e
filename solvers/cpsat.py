"""OR-Tools CP-SAT (plugin ``cpsat``): one ``AddAtMostOne`` per presolved conflict set, integer weights.

The model is written straight into CP-SAT's model proto through ``ortools.sat.python.cp_model_helper``
(the binding that ``cp_model.CpModel`` wraps): the same model, three times faster to build from arrays, and
without importing ``cp_model``, which imports pandas (0.7 s) only for its pandas helpers.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import ClassVar

import numpy as np

from packing import Termination
from registry import checked_settings
from solvers._base import (
    Availability,
    Capabilities,
    Result,
    Setting,
    Stopwatch,
    distribution_version,
    package_availability,
)
from solvers._cpsat_run import integer_weights, interruptible, set_parameters
from solvers._exact import ExactSolver
from solvers._model import CliqueModel

#: Most CP-SAT search workers a solve may ask for (CP-SAT's own portfolio has a few dozen subsolvers).
MAX_WORKERS = 64


class CpSatSolver(ExactSolver):
    """Eq. 3 as a CP-SAT model: a Boolean per item, ``AddAtMostOne`` per clique, a linear cap row.

    Parameters
    ----------
    workers : int
        CP-SAT search workers. One (the default) is deterministic for a given seed; more may be faster
        on hard instances but can return a different optimum among exact ties.
    """

    name: ClassVar[str] = "cpsat"
    capabilities: ClassVar[Capabilities] = Capabilities(
        exact=True, time_limit=True, minimum_cover=True, warm_start=True
    )
    settings: ClassVar[tuple[Setting, ...]] = (
        Setting(
            "workers",
            int,
            1,
            "CP-SAT search workers (1 is deterministic for a seed)",
            low=1,
            high=MAX_WORKERS,
        ),
    )

    def __init__(self, workers: int = 1) -> None:
        self.workers = int(checked_settings(self, {"workers": workers})["workers"])

    @classmethod
    def availability(cls) -> Availability:
        """Available when the ``ortools`` distribution is installed."""
        return package_availability("ortools", hint="pip install ortools")

    def solve_colouring(self, problem, start, lower, *, time_limit, seed):
        """The fewest expressions covering every item, as CP-SAT's colouring model (`solvers._colouring`)."""
        from solvers._colouring import colour_cpsat

        return colour_cpsat(problem, start, lower, time_limit, seed)

    def solve_model(
        self, model: CliqueModel, *, time_limit: float | None, seed: int, start: Sequence[int] = ()
    ) -> Result:
        """Solve the model, with ``start`` as a complete solution hint (docs/architecture.md: cut short
        by a time limit, CP-SAT may otherwise have no incumbent on film-sized problems). The hint is only
        a hint: ``repair_hint`` and ``fix_variables_to_their_hinted_value`` stay off, so optima are
        unchanged."""
        from ortools.sat.python import cp_model_helper

        clock = Stopwatch()
        proto = _model_proto(cp_model_helper, model)
        hinted = np.zeros(model.n_items, dtype=np.int64)
        hinted[np.asarray(start, dtype=np.int64)] = 1
        proto.solution_hint.vars.extend(range(model.n_items))
        proto.solution_hint.values.extend(hinted.tolist())
        parameters = cp_model_helper.SatParameters()
        set_parameters(parameters, time_limit, seed, self.workers)
        # The model is presolved already (maximal conflict sets, no dominated items: `packing._presolve`,
        # `solvers._reduce`) and its rows are maximal cliques (`solvers._cliques`): CP-SAT's own presolve and
        # its cut generators find little in it. Without them the 60 largest problems of a 2,000-shape
        # sequence solve in half the time (same optima; every solve is still proved optimal). For the same
        # reasons the rows all go into its LP at once (they are the tight ones), no symmetry is searched for
        # (the tie-break of `packing` leaves none among the weights) and no inprocessing runs between
        # restarts: 14% off the search of that sequence's 211 solves.
        parameters.cp_model_presolve = False
        parameters.cut_level = 0
        parameters.add_lp_constraints_lazily = False
        parameters.symmetry_level = 0
        parameters.use_sat_inprocessing = False
        solver = cp_model_helper.SolveWrapper()
        solver.set_parameters(parameters)
        build_time = clock.lap()
        response = interruptible(lambda: solver.solve(proto), solver.stop_search)
        solve_time = clock.lap()
        status = response.status
        found = cp_model_helper.CpSolverStatus
        version = f"ortools {distribution_version('ortools')}"
        if status not in (found.OPTIMAL, found.FEASIBLE, found.UNKNOWN):
            message = f"CP-SAT stopped with status {status.name}"
            return Result((), Termination.ERROR, None, build_time, solve_time, version, message)
        items: tuple[int, ...] = ()
        if status in (found.OPTIMAL, found.FEASIBLE):
            values = np.asarray(response.solution)[: model.n_items]
            items = tuple(np.flatnonzero(values).tolist())
        # The bound is on the scaled integers; add the worst-case rounding so it stays a true bound.
        scale = integer_weights(model.weights)[1]
        bound = (response.best_objective_bound + 0.5 * model.n_items) / scale
        termination = Termination.OPTIMAL if status == found.OPTIMAL else Termination.TIME_LIMIT
        return Result(items, termination, bound, build_time, solve_time, version)


def _model_proto(cp_model_helper, model: CliqueModel):
    """CP-SAT's model proto of the clique model: a Boolean per item, ``at_most_one`` per clique, the cap as
    a linear row, and ``maximize`` of the integer weights (as ``CpModel.maximize`` writes it: minimise the
    negated sum, scaling factor -1)."""
    proto = cp_model_helper.CpModelProto()
    n_items = model.n_items
    for _ in range(n_items):
        proto.variables.add().domain.extend((0, 1))
    starts = model.row_starts.tolist()
    items = model.row_items.tolist()
    for a, b in zip(starts[:-1], starts[1:], strict=True):
        proto.constraints.add().at_most_one.literals.extend(items[a:b])
    if model.cap is not None:
        linear = proto.constraints.add().linear
        linear.vars.extend(range(n_items))
        linear.coeffs.extend(model.shape_counts.tolist())
        linear.domain.extend((-(2**63), model.cap))  # (-inf, cap], as CpModel writes it
    scaled, _ = integer_weights(model.weights)
    proto.objective.vars.extend(range(n_items))
    proto.objective.coeffs.extend((-scaled).tolist())
    proto.objective.scaling_factor = -1.0
    return proto
