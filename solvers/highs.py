"""HiGHS through highspy's native arrays (plugin ``highs``): the presolved model of eq. 3 as one row-wise LP.

OR-Tools bundles its own HiGHS, and only the highspy wheel of that same HiGHS version loads beside it in one
process (docs/architecture.md), so availability checks the pair.
"""

from __future__ import annotations

import importlib.metadata
from collections.abc import Sequence
from typing import ClassVar

import numpy as np

from packing import Termination
from registry import checked_settings
from solvers._base import Availability, Capabilities, Result, Setting, Stopwatch, package_availability
from solvers._exact import ExactSolver
from solvers._highs_model import configured_highs, highs_solution, pass_model
from solvers._model import CliqueModel

#: HiGHS version bundled by each OR-Tools release line; highspy must match it to share a process.
ORTOOLS_BUNDLED_HIGHS = {"9.15": "1.12.0"}
#: HiGHS's MIP heuristics left out of the packing solves: feasibility jump, the root reduced-cost
#: heuristic, RENS and RINS only look for packings, and the start already is one (docs/architecture.md,
#: "What makes it fast").
PRIMAL_HEURISTICS_OFF = {
    "mip_heuristic_run_feasibility_jump": False,
    "mip_heuristic_run_root_reduced_cost": False,
    "mip_heuristic_run_rens": False,
    "mip_heuristic_run_rins": False,
}


class HighsSolver(ExactSolver):
    """Eq. 3 (cliques as at-most-one rows, the cap as one row) solved by HiGHS's branch and cut.

    Options: ``mip_rel_gap = mip_abs_gap = 0``, one thread, ``random_seed = seed``, native time limit, no
    restart after the root search (``mip_allow_restart``), and without the primal heuristics of
    `PRIMAL_HEURISTICS_OFF` (the start packing is given).

    Parameters
    ----------
    presolve : bool
        HiGHS's own presolve (off: HiGHS solves the model as the harness presolved it).
    mip_heuristic_effort : float in [0, 1], optional
        The share of HiGHS's MIP search spent in its primal heuristics (None: HiGHS's default).
    """

    name: ClassVar[str] = "highs"
    capabilities: ClassVar[Capabilities] = Capabilities(
        exact=True, time_limit=True, minimum_cover=True, warm_start=True
    )
    settings: ClassVar[tuple[Setting, ...]] = (
        Setting("presolve", bool, True, "HiGHS's own presolve before its branch and cut"),
        Setting(
            "mip_heuristic_effort",
            float,
            None,
            "share of the search spent in primal heuristics",
            low=0,
            high=1,
        ),
    )

    def __init__(self, presolve: bool = True, mip_heuristic_effort: float | None = None) -> None:
        given = {
            "presolve": presolve,
            **({} if mip_heuristic_effort is None else {"mip_heuristic_effort": mip_heuristic_effort}),
        }
        checked = checked_settings(self, given)
        self.presolve = bool(checked["presolve"])
        self.mip_heuristic_effort = checked.get("mip_heuristic_effort")

    def _options(self) -> dict[str, float | bool | str]:
        """The HiGHS options the settings ask for (none at their defaults: HiGHS's own choice)."""
        options: dict[str, float | bool | str] = {} if self.presolve else {"presolve": "off"}
        if self.mip_heuristic_effort is not None:
            options["mip_heuristic_effort"] = float(self.mip_heuristic_effort)
        return options

    @classmethod
    def availability(cls) -> Availability:
        """Available when highspy is installed and matches the HiGHS bundled by an installed OR-Tools."""
        found = package_availability("highspy", hint="pip install highspy")
        if not found:
            return found
        try:
            ortools = importlib.metadata.version("ortools")
        except importlib.metadata.PackageNotFoundError:
            return found
        bundled = ORTOOLS_BUNDLED_HIGHS.get(".".join(ortools.split(".")[:2]))
        if bundled is not None and found.version != bundled:
            return Availability.version_mismatch(
                found.version,
                f"highspy {found.version} cannot load beside ortools {ortools}, which bundles "
                f"HiGHS {bundled}; pip install highspy=={bundled}",
            )
        return found

    def solve_colouring(self, problem, start, lower, *, time_limit, seed):
        """The fewest expressions covering every item, as a HiGHS MILP of the colouring model."""
        from solvers._colouring import colour_highs

        return colour_highs(problem, start, lower, time_limit, seed)

    def solve_model(
        self, model: CliqueModel, *, time_limit: float | None, seed: int, start: Sequence[int] = ()
    ) -> Result:
        """Solve the model, with ``start`` given to HiGHS as a complete solution (``setSolution``)."""
        import highspy

        clock = Stopwatch()
        # The model is presolved already (`packing._presolve`, `solvers._reduce`, `solvers._cliques`): a
        # restart after HiGHS's root search finds little to remove and repeats the root's work. Without it
        # the 208 backend solves of a 2,000-shape film sequence take two thirds of the time (same optima).
        # The start is a good packing and the clique rows' LP is tight: the primal heuristics cost more than
        # they find (`PRIMAL_HEURISTICS_OFF`).
        highs = configured_highs(
            highspy,
            time_limit,
            seed,
            mip_abs_gap=0.0,
            mip_allow_restart=False,
            **PRIMAL_HEURISTICS_OFF,
            **self._options(),
        )
        matrix = model.matrix()
        n_items = model.n_items
        pass_model(
            highspy, highs, matrix, np.full(matrix.shape[0], -np.inf), model.upper(), model.weights,
            np.zeros(n_items), np.ones(n_items), maximise=True,
        )  # fmt: skip
        values = np.zeros(n_items)
        values[np.asarray(start, dtype=np.int64)] = 1.0
        highs.setSolution(highs_solution(highspy, values))
        build_time = clock.lap()
        highs.run()
        solve_time = clock.lap()
        status = highs.getModelStatus()
        info = highs.getInfo()
        has_incumbent = info.primal_solution_status == 2  # kSolutionStatusFeasible
        items: tuple[int, ...] = ()
        if has_incumbent:
            values = np.asarray(highs.getSolution().col_value)
            items = tuple(np.flatnonzero(values > 0.5).tolist())
        bound = float(info.mip_dual_bound) if np.isfinite(info.mip_dual_bound) else None
        version = f"highspy {highs.version()}"
        if status == highspy.HighsModelStatus.kOptimal:
            return Result(items, Termination.OPTIMAL, bound, build_time, solve_time, version)
        if status == highspy.HighsModelStatus.kTimeLimit:
            return Result(items, Termination.TIME_LIMIT, bound, build_time, solve_time, version)
        message = f"HiGHS stopped with model status {highs.modelStatusToString(status)}"
        return Result((), Termination.ERROR, None, build_time, solve_time, version, message)
