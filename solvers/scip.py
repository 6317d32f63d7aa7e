"""SCIP through PySCIPOpt (plugin ``scip``, optional: ``pip install expression-packing-harness[scip]``).

PySCIPOpt 6.3 (SCIP 10) was checked to load and solve beside OR-Tools 9.15 and highspy 1.12 in one
process, in either import order (tests/solvers/test_solvers_coexist.py), so it runs in-process.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import ClassVar

import numpy as np

from packing import Termination
from solvers._base import Availability, Capabilities, Result, Stopwatch, package_availability
from solvers._exact import ExactSolver
from solvers._model import CliqueModel


class ScipSolver(ExactSolver):
    """Eq. 3 after presolve solved by SCIP (gaps 0, one thread, seeded, native time limit)."""

    name: ClassVar[str] = "scip"
    capabilities: ClassVar[Capabilities] = Capabilities(exact=True, time_limit=True, warm_start=True)

    @classmethod
    def availability(cls) -> Availability:
        """Available when the optional ``PySCIPOpt`` distribution is installed."""
        return package_availability(
            "PySCIPOpt", "pyscipopt", hint="pip install expression-packing-harness[scip]"
        )

    def solve_model(
        self, model: CliqueModel, *, time_limit: float | None, seed: int, start: Sequence[int] = ()
    ) -> Result:
        return solve_clique_model(model, time_limit, seed, start)


def solve_clique_model(
    model: CliqueModel, time_limit: float | None, seed: int, start: Sequence[int] = ()
) -> Result:
    """Build and solve the clique model with PySCIPOpt; ``start`` is added as a (complete) partial
    solution, which SCIP checks and keeps as its first incumbent."""
    import pyscipopt

    clock = Stopwatch()
    scip = pyscipopt.Model("expression")
    scip.hideOutput()
    scip.setParam("limits/gap", 0.0)
    scip.setParam("limits/absgap", 0.0)
    scip.setParam("randomization/randomseedshift", int(seed))
    if time_limit is not None:
        scip.setParam("limits/time", float(time_limit))
    chosen = [scip.addVar(f"x{i}", vtype="B", obj=float(w)) for i, w in enumerate(model.weights)]
    scip.setMaximize()
    for r in range(model.n_rows):
        scip.addCons(pyscipopt.quicksum(chosen[i] for i in model.row(r).tolist()) <= 1)
    if model.cap is not None:
        counts = model.shape_counts.tolist()
        scip.addCons(pyscipopt.quicksum(c * x for c, x in zip(counts, chosen, strict=True)) <= model.cap)
    hinted = set(int(i) for i in start)
    given = scip.createPartialSol()
    for i, x in enumerate(chosen):
        scip.setSolVal(given, x, 1.0 if i in hinted else 0.0)
    scip.addSol(given)
    build_time = clock.lap()
    scip.optimize()
    solve_time = clock.lap()
    status = scip.getStatus()
    version = f"pyscipopt {pyscipopt.__version__}, scip {scip.version()}"
    items: tuple[int, ...] = ()
    if scip.getNSols() > 0:
        best = scip.getBestSol()
        values = np.array([scip.getSolVal(best, x) for x in chosen])
        items = tuple(np.flatnonzero(values > 0.5).tolist())
    bound = float(scip.getDualbound())
    bound = bound if np.isfinite(bound) else None
    if status == "optimal":
        return Result(items, Termination.OPTIMAL, bound, build_time, solve_time, version)
    if status == "timelimit":
        return Result(items, Termination.TIME_LIMIT, bound, build_time, solve_time, version)
    return Result((), Termination.ERROR, None, build_time, solve_time, version, f"SCIP status {status}")
