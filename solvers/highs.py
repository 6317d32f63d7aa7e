"""HiGHS through highspy's native arrays (plugin ``highs``): the presolved model of eq. 3 as one row-wise LP.

DESIGN.md, "Pitfalls": OR-Tools bundles its own HiGHS, and only the highspy wheel of that same HiGHS
version loads beside it in one process, so availability checks the pair.
"""

from __future__ import annotations

import importlib.metadata
from typing import ClassVar

import numpy as np

from packing import PackingProblem, Termination
from solvers._base import Availability, Capabilities, Stopwatch, package_availability
from solvers._exact import BackendResult, ExactSolverBase
from solvers._model import CliqueModel

#: HiGHS version bundled by each OR-Tools release line; highspy must match it to share a process.
ORTOOLS_BUNDLED_HIGHS = {"9.15": "1.12.0"}


class HighsSolver(ExactSolverBase):
    """Eq. 3 (cliques as at-most-one rows, the cap as one row) solved by HiGHS's branch and cut.

    Options: ``mip_rel_gap = mip_abs_gap = 0``, one thread, ``random_seed = seed``, native time limit.
    """

    name: ClassVar[str] = "highs"
    capabilities: ClassVar[Capabilities] = Capabilities(exact=True, time_limit=True)

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

    def _solve_model(
        self, problem: PackingProblem, model: CliqueModel, time_limit: float | None, seed: int
    ) -> BackendResult:
        import highspy

        clock = Stopwatch()
        highs = highspy.Highs()
        for option, value in (
            ("output_flag", False),
            ("threads", 1),
            ("random_seed", int(seed)),
            ("mip_rel_gap", 0.0),
            ("mip_abs_gap", 0.0),
        ):
            highs.setOptionValue(option, value)
        if time_limit is not None:
            highs.setOptionValue("time_limit", float(time_limit))
        highs.passModel(_highs_lp(highspy, model))
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
            return BackendResult(items, Termination.OPTIMAL, bound, build_time, solve_time, version)
        if status == highspy.HighsModelStatus.kTimeLimit:
            return BackendResult(items, Termination.TIME_LIMIT, bound, build_time, solve_time, version)
        message = f"HiGHS stopped with model status {highs.modelStatusToString(status)}"
        return BackendResult((), Termination.ERROR, None, build_time, solve_time, version, message)


def _highs_lp(highspy, model: CliqueModel):
    """``highspy.HighsLp`` of the clique model: maximise, binaries, one row per clique plus the cap row."""
    n_items, n_rows = model.n_items, model.n_rows
    row_starts, row_items = model.row_starts, model.row_items
    coefficients = np.ones(row_items.size)
    row_upper = np.ones(n_rows)
    if model.cap is not None:
        row_starts = np.append(row_starts, row_starts[-1] + n_items)
        row_items = np.concatenate([row_items, np.arange(n_items)])
        coefficients = np.concatenate([coefficients, model.shape_counts.astype(np.float64)])
        row_upper = np.append(row_upper, float(model.cap))
    lp = highspy.HighsLp()
    lp.num_col_ = n_items
    lp.num_row_ = row_upper.size
    lp.sense_ = highspy.ObjSense.kMaximize
    lp.col_cost_ = model.weights
    lp.col_lower_ = np.zeros(n_items)
    lp.col_upper_ = np.ones(n_items)
    lp.row_lower_ = np.full(row_upper.size, -highspy.kHighsInf)
    lp.row_upper_ = row_upper
    lp.a_matrix_.format_ = highspy.MatrixFormat.kRowwise
    lp.a_matrix_.num_col_ = n_items
    lp.a_matrix_.num_row_ = row_upper.size
    lp.a_matrix_.start_ = row_starts.astype(np.int32)
    lp.a_matrix_.index_ = row_items.astype(np.int32)
    lp.a_matrix_.value_ = coefficients
    lp.integrality_ = [highspy.HighsVarType.kInteger] * n_items
    return lp
