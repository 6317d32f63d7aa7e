"""CBC through python-mip's in-memory API (plugin ``cbc-mip``), in its own worker process.

python-mip's CBC library fails to load beside OR-Tools in one process, in either import order
(docs/architecture.md), so this plugin never imports ``mip`` in the caller: `solve_clique_model` runs in a
persistent worker (`solvers._worker`), which measures the build and solve times itself.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import ClassVar

import numpy as np

from packing import Termination
from solvers._base import Availability, Capabilities, Result, Stopwatch, package_availability
from solvers._exact import ExactSolver
from solvers._model import CliqueModel
from solvers._worker import worker

#: Seconds the caller waits for the worker beyond the solver's own time limit before giving up on it.
WORKER_GRACE = 120.0


class MipCbcSolver(ExactSolver):
    """Eq. 3 after presolve, solved by python-mip's CBC (gaps 0, cutoff increment 0, weights scaled to at
    most 1, one thread, seeded, native time limit: see `solvers._cbc.CBC_INCREMENT`)."""

    name: ClassVar[str] = "cbc-mip"
    capabilities: ClassVar[Capabilities] = Capabilities(
        exact=True, time_limit=True, isolated_process=True, warm_start=True
    )

    @classmethod
    def availability(cls) -> Availability:
        """Available when the ``mip`` distribution is installed (it is only imported in the worker)."""
        return package_availability("mip", hint="pip install mip")

    def solve_model(
        self, model: CliqueModel, *, time_limit: float | None, seed: int, start: Sequence[int] = ()
    ) -> Result:
        """Solve the model in the worker; the start travels with it, as a tuple of item indices."""
        timeout = None if time_limit is None else time_limit + WORKER_GRACE
        return worker(self.name).call(
            "solvers.cbc_mip:solve_clique_model", model, time_limit, seed, tuple(start), timeout=timeout
        )


def solve_clique_model(
    model: CliqueModel, time_limit: float | None, seed: int, start: Sequence[int] = ()
) -> Result:
    """Build and solve the clique model with python-mip (runs inside the worker process); ``start`` is
    CBC's initial solution (``Model.start``, every variable given)."""
    import mip
    from mip.cbc import cbc_set_parameter

    from solvers._cbc import CBC_INCREMENT, objective_scale

    clock = Stopwatch()
    lp = mip.Model(sense=mip.MAXIMIZE, solver_name=mip.CBC)
    lp.verbose = 0
    lp.threads = 1
    lp.seed = int(seed)
    lp.max_mip_gap = 0.0
    lp.max_mip_gap_abs = 0.0
    # python-mip sets the gaps, not CBC's cutoff increment (1e-4 absolute by default in this CBC).
    cbc_set_parameter(lp.solver, "increment", f"{CBC_INCREMENT:g}")
    scale = objective_scale(model.weights)
    chosen = [lp.add_var(var_type=mip.BINARY, obj=float(w) * scale) for w in model.weights]
    for r in range(model.n_rows):
        lp.add_constr(mip.xsum(chosen[i] for i in model.row(r).tolist()) <= 1)
    if model.cap is not None:
        lp.add_constr(
            mip.xsum(c * x for c, x in zip(model.shape_counts.tolist(), chosen, strict=True)) <= model.cap
        )
    hinted = set(int(i) for i in start)
    lp.start = [(x, 1.0 if i in hinted else 0.0) for i, x in enumerate(chosen)]
    build_time = clock.lap()
    status = lp.optimize(max_seconds=time_limit if time_limit is not None else mip.INF)
    solve_time = clock.lap()
    version = f"mip {mip.__version__}, cbc"
    items: tuple[int, ...] = ()
    if status in (mip.OptimizationStatus.OPTIMAL, mip.OptimizationStatus.FEASIBLE) and lp.num_solutions:
        values = np.array([x.x for x in chosen], dtype=float)
        items = tuple(np.flatnonzero(values > 0.5).tolist())
    bound = float(lp.objective_bound) / scale if np.isfinite(lp.objective_bound) else None
    if status is mip.OptimizationStatus.OPTIMAL:
        return Result(items, Termination.OPTIMAL, bound, build_time, solve_time, version)
    if status in (mip.OptimizationStatus.FEASIBLE, mip.OptimizationStatus.NO_SOLUTION_FOUND):
        return Result(items, Termination.TIME_LIMIT, bound, build_time, solve_time, version)
    message = f"python-mip stopped with status {status.name}"
    return Result((), Termination.ERROR, None, build_time, solve_time, version, message)
