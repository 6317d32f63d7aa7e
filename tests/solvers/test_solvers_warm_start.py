"""Exact solves start from Algorithm 2's packing (``Capabilities.warm_start``), and a greedy answer at a time
limit is recorded in ``Solution.fallback`` (Carrigan et al. 2020, eq. 3, Algorithm 1, sec. 4.5.2)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import packing
import rigs
import solvers
from packing import Termination
from solvers import Capabilities, Result
from solvers._exact import start_packing
from solvers._reduce import reduce_problem
from solvers.greedy import greedy_items
from solvers.testing import check_packing, check_solver, hard_problem
from tests.solvers.plugin_variants import available, variant

EXACT = ("cpsat", "highs", "cbc-mip", "cbc-pulp", "scip")
TOLERANCE = 1e-9


def _without_start(name: str):
    """The plugin ``name`` declaring no warm start: it solves as before the start existed."""
    capabilities = replace(type(available(name).plugin).capabilities, warm_start=False)
    return variant(name, "NoStart", capabilities=capabilities)


def _start_in_problem(problem: packing.PackingProblem) -> tuple[int, ...]:
    reduction = reduce_problem(problem, False)
    return reduction.items(start_packing(problem, reduction))


@pytest.mark.parametrize("seed", [0, 1])
def test_the_start_is_a_valid_packing_at_least_as_good_as_the_kernels_greedy_one(seed: int) -> None:
    problem = hard_problem(seed)
    reduction = reduce_problem(problem, False)
    start = start_packing(problem, reduction)
    assert list(start) == sorted(set(start)) and all(0 <= i < reduction.model.n_items for i in start)
    items = reduction.items(start)
    check_packing(problem, items)
    assert problem.objective(items) > 0


@pytest.mark.parametrize("name", EXACT)
@pytest.mark.parametrize("seed", [0, 1])
def test_a_time_limited_answer_is_no_worse_than_greedy_nor_the_start(name: str, seed: int) -> None:
    loaded = available(name)
    problem = hard_problem(seed)
    solution = loaded.solve(problem, time_limit=0.02, seed=seed)
    assert solution.termination in (Termination.OPTIMAL, Termination.TIME_LIMIT), solution.message
    check_packing(problem, solution.items)
    found = problem.objective(solution.items)
    greedy = problem.objective(greedy_items(problem))
    start = problem.objective(_start_in_problem(problem))
    assert found >= greedy - TOLERANCE and found >= start - TOLERANCE
    assert solution.bound is not None and solution.bound >= solution.objective
    if solution.fallback:  # the greedy packing was answered: exactly one of the two greedy packings
        assert solution.fallback == "greedy" and solution.termination is Termination.TIME_LIMIT
        assert solution.items in (tuple(sorted(greedy_items(problem))), _start_in_problem(problem))


class _Scripted(solvers.ExactSolver):
    """An exact plugin whose backend answers as scripted, recording the start it was given (on the whole
    kernel, however small: no reduced-cost fixing, no enumeration)."""

    name = "scripted"
    capabilities = Capabilities(exact=True, time_limit=True, warm_start=True)
    _fixes_by_reduced_costs = False
    _enumerates_small_kernels = False
    answer: str = "none"
    starts: list[tuple[int, ...]] = []

    @classmethod
    def availability(cls):
        return solvers.Availability.available("1.0")

    def solve_model(self, model, *, time_limit, seed, start=()):
        type(self).starts.append(tuple(start))
        if self.answer == "none":
            return Result((), Termination.TIME_LIMIT)
        best = np.flatnonzero(model.weights == model.weights.max())[:1]
        if self.answer == "worse":  # one item, as no greedy packing of the hard problem is
            return Result(best, Termination.TIME_LIMIT, bound=float(model.weights.sum()))
        optimal = self.answer == "start-optimal"
        return Result(start, Termination.OPTIMAL if optimal else Termination.TIME_LIMIT)


@pytest.mark.parametrize(
    ("answer", "fallback"), [("none", "greedy"), ("worse", "greedy"), ("start", ""), ("start-optimal", "")]
)
def test_fallback_is_set_exactly_when_the_greedy_packing_is_answered(answer: str, fallback: str) -> None:
    problem = hard_problem(0)
    plugin = type("Scripted", (_Scripted,), {"answer": answer, "starts": []})
    solution = solvers.load(plugin).solve(problem, time_limit=0.05)
    start = _start_in_problem(problem)
    assert plugin.starts == [start_packing(problem, reduce_problem(problem, False))]
    assert solution.fallback == fallback
    if fallback:
        assert "Algorithm 2's packing" in solution.message
        assert problem.objective(solution.items) >= problem.objective(start) - TOLERANCE
    else:
        assert solution.items == start and "Algorithm 2" not in solution.message


@pytest.mark.filterwarnings("ignore::packing.MissingTargetWarning")
def test_fallback_reaches_the_expression_and_its_record() -> None:
    from harness._rows import expression_record

    plugin = type("Scripted", (_Scripted,), {"answer": "none", "starts": []})
    expressions = packing.sequence(rigs.generate("tiny"), solvers.load(plugin), time_limit=0.05, jmax=1)
    assert expressions[0].fallback == "greedy"
    assert expression_record(expressions[0])["fallback"] == "greedy"


def test_a_plugin_without_start_support_gets_none_and_passes_the_checks() -> None:
    seen: list[dict] = []

    class NoStart(solvers.ExactSolver):  # written before ``start`` existed
        name = "no-start"
        capabilities = Capabilities(exact=True, time_limit=True)

        @classmethod
        def availability(cls):
            return solvers.Availability.available("1.0")

        def solve_model(self, model, *, time_limit, seed):
            seen.append({"time_limit": time_limit, "seed": seed})
            return available("highs").plugin.solve_model(model, time_limit=time_limit, seed=seed)

    assert check_solver(NoStart) == list(solvers.testing.CHECKS)
    assert seen


def test_built_in_exact_solvers_declare_the_warm_start() -> None:
    for name in EXACT:
        assert solvers.get(name).capabilities.warm_start, name
    assert not solvers.get("naive-pulp-cbc").capabilities.warm_start  # the formulation as published


@pytest.mark.parametrize("name", ["cpsat", "highs"])
@pytest.mark.parametrize("preset", ["arkit52", "female"])
def test_the_start_leaves_the_optima_of_a_whole_sequence_unchanged(name: str, preset: str) -> None:
    rig = rigs.generate(preset)
    with pytest.warns(packing.MissingTargetWarning):
        analysis = packing.analyse(rig)
    hinted = packing.sequence(rig, available(name), analysis=analysis)
    plain = packing.sequence(rig, _without_start(name), analysis=analysis)
    assert all(e.termination is Termination.OPTIMAL and not e.fallback for e in hinted + plain)
    assert [e.objective for e in hinted] == pytest.approx([e.objective for e in plain], rel=TOLERANCE)
