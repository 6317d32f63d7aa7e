"""CBC through PuLP on the presolved model (plugin ``cbc-pulp``)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import ClassVar

import numpy as np

from registry import checked_settings
from solvers._base import Availability, Capabilities, Result, Setting, Stopwatch
from solvers._cbc import CBC_CHOICES, cbc_availability, find_cbc, objective_scale, run_cbc
from solvers._exact import ExactSolver
from solvers._model import CliqueModel


class PulpCbcSolver(ExactSolver):
    """Eq. 3 after presolve (one row per conflict set, one cap row), written by PuLP and solved by CBC.

    Expressions are built from coefficient lists (``LpAffineExpression``), not by summing terms in
    Python. CBC runs as a subprocess with ``ratio 0``, ``allow 0``, ``increment 0``, one thread and a fixed
    seed, on weights scaled to at most 1 (`solvers._cbc.objective_scale`).

    Parameters
    ----------
    cbc : {"auto", "cbcbox", "bundled"}
        CBC executable: ``auto`` prefers the newer one of the ``cbcbox`` wheel over PuLP's bundled 2.10.3.
    """

    name: ClassVar[str] = "cbc-pulp"
    capabilities: ClassVar[Capabilities] = Capabilities(exact=True, time_limit=True, warm_start=True)

    settings: ClassVar[tuple[Setting, ...]] = (
        Setting("cbc", str, "auto", "the CBC executable", choices=CBC_CHOICES),
    )

    def __init__(self, cbc: str = "auto") -> None:
        self.cbc = str(checked_settings(self, {"cbc": cbc})["cbc"])

    @classmethod
    def availability(cls) -> Availability:
        """PuLP installed and a CBC executable found (cbcbox's or PuLP's own)."""
        return cbc_availability()

    def solve_model(
        self, model: CliqueModel, *, time_limit: float | None, seed: int, start: Sequence[int] = ()
    ) -> Result:
        """Solve the model with CBC, ``start`` given as initial values (PuLP's ``warmStart``: CBC's
        ``-mips`` file)."""
        import pulp

        binary = find_cbc(self.cbc)
        if binary is None:
            raise RuntimeError(f"no CBC executable found for cbc={self.cbc!r}")
        clock = Stopwatch()
        lp = pulp.LpProblem("expression", pulp.LpMaximize)
        chosen = [pulp.LpVariable(f"x{i}", cat=pulp.LpBinary) for i in range(model.n_items)]
        scale = objective_scale(model.weights)
        weights = (model.weights * scale).tolist()
        lp.setObjective(pulp.LpAffineExpression(zip(chosen, weights, strict=True)))
        for r in range(model.n_rows):
            row = pulp.LpAffineExpression([(chosen[i], 1) for i in model.row(r).tolist()])
            lp.addConstraint(pulp.LpConstraint(row, pulp.LpConstraintLE, rhs=1), name=f"clique{r}")
        if model.cap is not None:
            row = pulp.LpAffineExpression(zip(chosen, model.shape_counts.tolist(), strict=True))
            lp.addConstraint(pulp.LpConstraint(row, pulp.LpConstraintLE, rhs=model.cap), name="cap")
        hinted = set(int(i) for i in start)
        for i, x in enumerate(chosen):
            x.setInitialValue(1 if i in hinted else 0)
        build_time = clock.lap()
        outcome, solve_time = run_cbc(lp, binary, time_limit, seed, warm_start=True)
        version = f"pulp {pulp.__version__}, {binary.version}"
        items: tuple[int, ...] = ()
        if outcome.has_solution:
            values = np.array([v.varValue or 0.0 for v in chosen])
            items = tuple(np.flatnonzero(values > 0.5).tolist())
        bound = None if outcome.bound is None else outcome.bound / scale
        return Result(items, outcome.termination, bound, build_time, solve_time, version, outcome.message)
