"""The paper's formulation as published (plugin ``naive-pulp-cbc``): the baseline of every speed figure.

Carrigan et al. 2020, sec. 4.2 and 4.5.1: one binary per blendshape, one PuLP constraint per vertex
(eq. 3b, no presolve) and one equality row per symmetry pair (eq. 3d): "the number of linear
constraints is N + P". The model is built the way a PuLP user writes it (``lpSum`` per vertex in a
Python loop) and solved by PuLP's own bundled CBC (the executable of ``PULP_CBC_CMD``, which
``LpProblem.solve()`` runs when no newer ``cbc`` is on the PATH). ``NaivePulpCbcSolver(cbc="auto")``
runs the newer CBC of ``cbc-pulp`` instead, so that the two then differ only in formulation.

A `PackingProblem` stores a symmetry pair as one item with the union of both shapes' active vertices
(sec. 4.4, "active vertices must be corrected"), not the two shapes' own vertex sets. The baseline
therefore gives the pair's first shape the union and its second shape none, tied by ``w_x - w_p = 0``,
with each shape weighing half the item. This has the paper's variables (K) and rows (vertices with an
active blendshape, plus P) and exactly the feasible set and optimum of eq. 3.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

import numpy as np

from registry import checked_settings
from solvers._base import Availability, Capabilities, Result, Setting, Stopwatch
from solvers._cbc import CBC_CHOICES, cbc_availability, find_cbc, objective_scale, run_cbc
from solvers._exact import ExactSolver
from solvers._model import CliqueModel

if TYPE_CHECKING:
    from packing import PackingProblem


class NaivePulpCbcSolver(ExactSolver):
    """Eq. 3 with one row per vertex, as published, through PuLP and CBC (no presolve).

    Parameters
    ----------
    cbc : {"bundled", "auto", "cbcbox"}
        CBC executable: PuLP's own (2.10.3, the default), or as for ``cbc-pulp``.
    """

    name: ClassVar[str] = "naive-pulp-cbc"
    capabilities: ClassVar[Capabilities] = Capabilities(exact=True, time_limit=True)
    reduces: ClassVar[bool] = False  # the formulation as published: every item and vertex row

    settings: ClassVar[tuple[Setting, ...]] = (
        Setting("cbc", str, "bundled", "the CBC executable", choices=CBC_CHOICES),
    )

    def __init__(self, cbc: str = "bundled") -> None:
        self.cbc = str(checked_settings(self, {"cbc": cbc})["cbc"])

    @classmethod
    def availability(cls) -> Availability:
        """PuLP installed with its bundled CBC executable."""
        return cbc_availability("bundled")

    def solve_problem(
        self, problem: PackingProblem, model: CliqueModel, *, time_limit: float | None, seed: int
    ) -> Result:
        """One PuLP row per vertex, pair and apart constraint, as published (``model`` is not used)."""
        import pulp
        import scipy.sparse as sp

        binary = find_cbc(self.cbc)
        if binary is None:
            raise RuntimeError(f"no CBC executable found for cbc={self.cbc!r}")
        clock = Stopwatch()
        lp = pulp.LpProblem("expression", pulp.LpMaximize)
        shape_vars = {}
        for shapes in problem.items:
            for shape in shapes:
                shape_vars[shape] = pulp.LpVariable(f"w{shape}", cat=pulp.LpBinary)
        carrier = [shape_vars[shapes[0]] for shapes in problem.items]  # holds the item's vertex set
        scale = objective_scale(problem.weights)  # CBC's tolerances are absolute (`solvers._cbc`)
        lp += pulp.lpSum(
            scale * problem.weights[item] / len(shapes) * shape_vars[shape]
            for item, shapes in enumerate(problem.items)
            for shape in shapes
        )
        by_vertex = sp.csc_matrix(problem.incidence)
        for vertex in range(by_vertex.shape[1]):
            active = by_vertex.indices[by_vertex.indptr[vertex] : by_vertex.indptr[vertex + 1]]
            if active.size:
                lp += pulp.lpSum(carrier[item] for item in active) <= 1, f"vertex{vertex}"
        for a, b in problem.apart:
            lp += carrier[a] + carrier[b] <= 1, f"apart{a}_{b}"
        for shapes in problem.items:
            for partner in shapes[1:]:
                lp += shape_vars[shapes[0]] - shape_vars[partner] == 0, f"pair{shapes[0]}_{partner}"
        if problem.cap is not None:
            lp += pulp.lpSum(shape_vars.values()) <= problem.cap, "cap"
        build_time = clock.lap()
        outcome, solve_time = run_cbc(lp, binary, time_limit, seed)
        version = f"pulp {pulp.__version__}, {binary.version}"
        items: tuple[int, ...] = ()
        if outcome.has_solution:
            values = np.array([v.varValue or 0.0 for v in carrier])
            items = tuple(np.flatnonzero(values > 0.5).tolist())
        message = "; ".join(
            filter(None, [f"{lp.numConstraints()} rows, {len(shape_vars)} variables", outcome.message])
        )
        bound = None if outcome.bound is None else outcome.bound / scale
        return Result(items, outcome.termination, bound, build_time, solve_time, version, message)
