"""Small kernels solved by listing their packings (`solvers._enumerate`): the optimum of eq. 3 that the
backends prove (Carrigan et al. 2020, eq. 3, sec. 6 cap, Algorithm 1), without running one."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import packing
import rigs
import solvers
from packing import Termination
from solvers._enumerate import ENUMERATION_MAX_ITEMS, enumerated_optimum
from solvers.testing import random_problem
from tests.solvers.plugin_variants import variant


def _backend_only(name: str):
    """The plugin ``name`` sending every kernel to its backend."""
    return variant(name, "Backend", _enumerates_small_kernels=False)


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 100_000),
    n_items=st.integers(0, ENUMERATION_MAX_ITEMS),
    density=st.floats(0.0, 0.9),
    cap=st.sampled_from([None, 1, 3, 6]),
)
def test_the_enumerated_optimum_is_the_best_packing_of_all_subsets(seed, n_items, density, cap):
    rng = np.random.default_rng(seed)
    weights = rng.uniform(-0.2, 1.0, n_items)
    counts = rng.integers(1, 3, n_items)
    upper = np.triu(rng.random((n_items, n_items)) < density, k=1)
    conflicts = upper | upper.T
    chosen = enumerated_optimum(weights, counts, cap, conflicts)

    def feasible(items):
        fits = cap is None or counts[list(items)].sum() <= cap
        return fits and not any(conflicts[a, b] for a, b in itertools.combinations(items, 2))

    best = max(
        (s for k in range(n_items + 1) for s in itertools.combinations(range(n_items), k) if feasible(s)),
        key=lambda items: weights[list(items)].sum(),
    )
    assert feasible(chosen) and list(chosen) == sorted(chosen)
    assert weights[list(chosen)].sum() == pytest.approx(weights[list(best)].sum(), abs=1e-12)


def test_more_items_than_the_enumeration_takes_are_refused():
    n_items = ENUMERATION_MAX_ITEMS + 1
    weights, counts = np.ones(n_items), np.ones(n_items, dtype=int)
    with pytest.raises(ValueError, match="at most"):
        enumerated_optimum(weights, counts, None, np.zeros((n_items, n_items), dtype=bool))


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 100_000),
    n_items=st.integers(2, 24),
    cap=st.sampled_from([None, 2, 4]),
)
def test_cpsat_answers_what_its_backend_answers_on_random_small_problems(seed, n_items, cap):
    problem = random_problem(n_items, 2 * n_items + 4, seed=seed, active=(2, 7), cap=cap)
    enumerated = solvers.get("cpsat").solve(problem)
    backend = _backend_only("cpsat").solve(problem)
    assert enumerated.termination is backend.termination is Termination.OPTIMAL
    assert enumerated.items == backend.items
    assert enumerated.objective == backend.objective


def test_small_problems_are_solved_without_the_backend():
    problem = random_problem(10, 40, seed=3, active=(2, 7))
    solution = solvers.get("cpsat").solve(problem)
    assert "enumeration" in solution.message
    assert solution.bound == pytest.approx(solution.objective)


@pytest.mark.parametrize("name", ["cpsat", "highs"])
@pytest.mark.parametrize(("preset", "cap"), [("female", None), ("toon", 3)])
def test_every_expression_of_a_sequence_is_the_backends(name, preset, cap):
    rig = rigs.generate(preset)
    analysis = packing.analyse(rig, rigs.warp(rig, "alien").neutral, max_per_expression=cap)
    enumerated = packing.sequence(rig, solvers.get(name), analysis=analysis)
    backend = packing.sequence(rig, _backend_only(name), analysis=analysis)
    packing.check(rig, enumerated, pairs=analysis.pairs, max_per_expression=cap)
    assert any("enumeration" in e.message for e in enumerated)
    assert [e.items for e in enumerated] == [e.items for e in backend]
    assert [e.objective for e in enumerated] == [e.objective for e in backend]
