"""Reduced-cost fixing (`solvers._fixing`) leaves the optimum of eq. 3 exactly as it is (Carrigan et al.
2020, eq. 3, Algorithm 1): every expression of a sequence solved with it has the plain path's items and
objective."""

from __future__ import annotations

import functools

import numpy as np
import pytest

import packing
import rigs
import solvers
import solvers._fixing as fixing
from packing import Termination
from solvers._cliques import grown_cliques, kernel_neighbourhoods
from solvers._exact import start_packing
from solvers._reduce import reduce_graph, reduce_problem
from solvers.testing import random_problem
from tests.solvers.plugin_variants import available, variant

EXACT = ("cpsat", "highs")


def _plain(name: str):
    """The plugin ``name`` without reduced-cost fixing."""
    return variant(name, "Unfixed", _fixes_by_reduced_costs=False)


@functools.cache
def _analysis(preset: str, seed: int):
    rig = rigs.generate(preset, seed=seed)
    return rig, packing.analyse(rig, rigs.warp(rig, "alien").neutral)


@pytest.mark.parametrize(
    ("name", "preset", "seed", "target_fractions"),
    [
        ("cpsat", "male", 0, (1.0,)),
        ("cpsat", "toon", 1, (0.0,)),
        ("cpsat", "arkit52", 2, (1.0, 0.5)),
        ("highs", "male", 1, (0.85,)),
        ("highs", "tiny", 0, ()),
    ],
)
def test_every_expression_matches_the_plain_path(monkeypatch, name, preset, seed, target_fractions):
    """Fixing on every kernel of two items or more (none solved by enumeration), with targets that fail often
    (1.0: the LP bound), never (0.0: the known packing) or in turn, gives the plain path's sequence."""
    rig, analysis = _analysis(preset, seed)
    plain = packing.sequence(rig, _plain(name), analysis=analysis)
    monkeypatch.setattr(fixing, "FIXING_MIN_ITEMS", 2)
    monkeypatch.setattr(solvers._exact, "ENUMERATION_MAX_ITEMS", 1)
    monkeypatch.setattr(fixing, "TARGET_FRACTIONS", target_fractions)
    fixed = packing.sequence(rig, available(name), analysis=analysis)
    packing.check(rig, fixed, pairs=analysis.pairs)
    assert [e.objective for e in fixed] == [e.objective for e in plain]
    assert [e.items for e in fixed] == [e.items for e in plain]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_bounds_hold_every_optimum_and_the_packing_is_valid(monkeypatch, seed):
    """``with_item`` bounds each item's best packing from above (checked by CP-SAT with the item forced in),
    so the items kept at the optimum's level hold every optimal item."""
    monkeypatch.setattr(fixing, "FIXING_MIN_ITEMS", 2)
    problem = random_problem(40, 60, seed=seed, active=(4, 9), pairs=0.2)
    reduction = reduce_problem(problem, False)
    closed = kernel_neighbourhoods(problem.conflict_bits, reduction.kept, problem.n_items)
    model = grown_cliques(reduction.model, closed)
    costs = fixing.reduced_costs(model, start_packing(problem, reduction))
    assert costs is not None
    adjacency = model.conflict_graph().toarray()
    chosen = np.zeros(model.n_items, dtype=bool)
    chosen[list(costs.packing)] = True
    assert not (adjacency & chosen[:, None] & chosen[None, :]).any()
    cpsat = available("cpsat").plugin
    best = cpsat.solve_model(model, time_limit=None, seed=0)
    optimum = costs.objective(best.items)
    assert costs.bound >= optimum - 1e-12 and costs.objective(costs.packing) <= optimum + 1e-12
    for item in range(model.n_items):
        forced = model.restricted(np.flatnonzero(~adjacency[item]))  # the item and its non-neighbours
        position = int(np.count_nonzero(~adjacency[item][:item]))
        with_item = cpsat.solve_model(forced, time_limit=None, seed=0)
        value = costs.objective(np.flatnonzero(~adjacency[item])[list(with_item.items)])
        if position not in with_item.items:
            value += model.weights[item]
        assert costs.with_item[item] >= value - 1e-9
    assert set(best.items) <= set(costs.kept(optimum).tolist())


@pytest.mark.parametrize("seed", [0, 1])
def test_the_bound_is_the_lp_optimum_and_the_duals_are_complementary(monkeypatch, seed):
    """The duals HiGHS answers prove the LP relaxation's optimum itself (strong duality), checked against
    SciPy's ``linprog``: duals of the wrong sign or of another LP would still give a valid bound, only a
    weak one, and fix nothing."""
    from scipy.optimize import linprog

    monkeypatch.setattr(fixing, "FIXING_MIN_ITEMS", 2)
    problem = random_problem(60, 80, seed=seed, active=(4, 9), pairs=0.2, cap=12)
    reduction = reduce_problem(problem, True)
    closed = kernel_neighbourhoods(problem.conflict_bits, reduction.kept, problem.n_items)
    model = grown_cliques(reduction.cut_model(), closed)
    costs = fixing.reduced_costs(model, start_packing(problem, reduction))
    assert costs is not None
    relaxed = linprog(-model.weights, A_ub=model.matrix(), b_ub=model.upper(), bounds=(0, 1), method="highs")
    assert relaxed.status == 0
    assert costs.bound == pytest.approx(-relaxed.fun, rel=1e-9, abs=1e-12)
    assert costs.bound < float(model.weights.clip(min=0).sum()) - 1e-6  # (a proof, not the trivial bound)


@pytest.mark.parametrize("cap", [None, 10])
def test_items_dominated_once_others_are_fixed_out_are_not_solved_and_the_optimum_stays(monkeypatch, cap):
    """With the items of low bounds left out, some kept items are dominated by others and the backend does
    not see them; every answer is still the plain solver's optimum."""
    monkeypatch.setattr(fixing, "FIXING_MIN_ITEMS", 2)
    sizes = []

    def recording(weights, counts, closed, cap_binds):
        kept, taken = reduce_graph(weights, counts, closed, cap_binds)
        sizes.append((weights.size, kept.size + taken.size))
        return kept, taken

    monkeypatch.setattr(fixing, "reduce_graph", recording)
    for seed in range(6):
        problem = random_problem(80, 60, seed=seed, active=(2, 6), pairs=0.2, cap=cap)
        fixed = available("cpsat").solve(problem, time_limit=None, seed=0)
        plain = _plain("cpsat").solve(problem, time_limit=None, seed=0)
        assert fixed.termination is Termination.OPTIMAL
        assert fixed.items == plain.items and fixed.objective == plain.objective
    assert any(solved < kept for kept, solved in sizes), sizes


def test_a_time_limited_fixed_solve_keeps_a_valid_bound(monkeypatch):
    """Cut short, the answer's bound covers the packings holding a left-out item too."""
    monkeypatch.setattr(fixing, "FIXING_MIN_ITEMS", 2)
    loaded = available("cpsat")
    problem = random_problem(150, 200, seed=3, active=(6, 12), pairs=0.2)
    solution = loaded.solve(problem, time_limit=0.001, seed=0)
    assert solution.bound is not None and solution.bound >= solution.objective - 1e-9
    full = _plain("cpsat").solve(problem, time_limit=None, seed=0)
    assert solution.bound >= full.objective - 1e-9


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_the_kernels_conflicts_given_to_fixing_are_the_models_own(monkeypatch, seed):
    """The exact path hands `reduced_costs` the kernel's neighbourhoods (no rebuild from the clique rows):
    they are the grown model's graph, so the bounds, packing and neighbourhoods of the fixing are too."""
    monkeypatch.setattr(fixing, "FIXING_MIN_ITEMS", 2)
    problem = random_problem(40, 60, seed=seed, active=(4, 9), pairs=0.2)
    reduction = reduce_problem(problem, False)
    closed = kernel_neighbourhoods(problem.conflict_bits, reduction.kept, problem.n_items)
    model = grown_cliques(reduction.model, closed)
    conflicts = packing.unpack_bit_rows(closed, model.n_items)
    np.fill_diagonal(conflicts, False)
    assert np.array_equal(conflicts, model.conflict_graph().toarray())
    start = start_packing(problem, reduction)
    given, rebuilt = fixing.reduced_costs(model, start, closed), fixing.reduced_costs(model, start)
    assert given is not None and rebuilt is not None and given.packing == rebuilt.packing
    assert np.array_equal(given.with_item, rebuilt.with_item) and given.bound == rebuilt.bound
    assert np.array_equal(given.closed, rebuilt.closed)


def test_the_backend_calls_of_fixing_share_the_time_limit(monkeypatch):
    """A fixed model whose target is missed is solved again, larger: the second call gets what the first
    left of the limit (at least `LEAST_SEARCH_SECONDS`), so the whole search stays within it."""
    import time

    import solvers._exact as exact

    monkeypatch.setattr(fixing, "FIXING_MIN_ITEMS", 2)
    monkeypatch.setattr(exact, "ENUMERATION_MAX_ITEMS", 1)
    monkeypatch.setattr(fixing, "TARGET_FRACTIONS", (1.0,))  # (the LP bound: missed, so a second call)
    limits: list[float | None] = []
    plugin = type(available("cpsat").plugin)

    def slow_solve_model(self, model, *, time_limit, seed, start=()):
        limits.append(time_limit)
        time.sleep(0.3)
        return plugin.solve_model(self, model, time_limit=time_limit, seed=seed, start=start)

    loaded = variant("cpsat", "Slow", solve_model=slow_solve_model)
    problem = random_problem(40, 60, seed=1, active=(4, 9), pairs=0.2)
    solution = loaded.solve(problem, time_limit=0.5, seed=0)
    assert len(limits) == 2 and limits[0] == 0.5
    assert exact.LEAST_SEARCH_SECONDS <= limits[1] <= 0.5 - 0.3  # (the first call took 0.3 s or more)
    assert solution.termination in (Termination.OPTIMAL, Termination.TIME_LIMIT)
