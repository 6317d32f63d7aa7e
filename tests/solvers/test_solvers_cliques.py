"""Clique rows grown to maximal cliques of the conflict graph (`solvers._cliques`): the same feasible packings
as the kernel's conflict sets, so every exact backend finds the same optimum at every expression of a
sequence as with the conflict sets as they are (Carrigan et al. 2020, eq. 3, Algorithm 1)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import packing
import rigs
import solvers
from solvers._cliques import grown_cliques, kernel_neighbourhoods
from solvers._reduce import reduce_problem
from solvers.testing import random_problem
from tests.solvers.plugin_variants import available, variant

EXACT = ("cpsat", "highs", "cbc-mip", "scip")


def _kernel(seed: int, cap: int | None):
    problem = random_problem(12 + seed % 5, 30, seed=seed, active=(2, 8), cap=cap)
    cap_binds = cap is not None and cap < int(problem.item_shape_counts.sum())
    reduction = reduce_problem(problem, cap_binds)
    closed = kernel_neighbourhoods(problem.conflict_bits, reduction.kept, problem.n_items)
    return problem, reduction, closed


def _conflicts(closed: np.ndarray, n_items: int) -> np.ndarray:
    """(I, I) bool: items i != j that conflict."""
    bits = np.unpackbits(closed.astype(">u8").view(np.uint8), axis=1, count=n_items).astype(bool)
    np.fill_diagonal(bits, False)
    return bits


def _feasible(model, chosen: tuple[int, ...]) -> bool:
    picked = np.zeros(model.n_items, dtype=bool)
    picked[list(chosen)] = True
    rows_ok = all(picked[model.row(r)].sum() <= 1 for r in range(model.n_rows))
    return rows_ok and (model.cap is None or model.shape_counts[picked].sum() <= model.cap)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 100_000), cap=st.sampled_from([None, 2, 4]))
def test_grown_rows_are_maximal_cliques_holding_the_given_rows(seed, cap):
    problem, reduction, closed = _kernel(seed, cap)
    model = reduction.model
    grown = grown_cliques(model, closed)
    conflicts = _conflicts(closed, model.n_items)
    rows = [set(grown.row(r).tolist()) for r in range(grown.n_rows)]
    assert len({frozenset(row) for row in rows}) == len(rows)  # no duplicate
    for row in rows:
        assert all(conflicts[a, b] for a, b in itertools.combinations(sorted(row), 2))  # a clique
        outside = [j for j in range(model.n_items) if j not in row]
        assert not any(all(conflicts[j, i] for i in row) for j in outside)  # maximal
    for r in range(model.n_rows):
        assert any(set(model.row(r).tolist()) <= row for row in rows)
    assert np.array_equal(grown.weights, model.weights) and grown.cap == model.cap


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 100_000), cap=st.sampled_from([None, 3]))
def test_grown_rows_allow_exactly_the_packings_the_conflict_sets_allow(seed, cap):
    problem, reduction, closed = _kernel(seed, cap)
    model = reduction.model
    model_items = range(min(model.n_items, 14))  # every subset of (at most) the first 14 items
    grown = grown_cliques(model, closed)
    for size in range(len(model_items) + 1):
        for chosen in itertools.combinations(model_items, size):
            assert _feasible(model, chosen) == _feasible(grown, chosen)


def _plain(name: str):
    """The plugin ``name`` solving the kernel's conflict sets as they are (no grown cliques)."""
    return variant(name, "Plain", _grows_cliques=False)


@pytest.mark.parametrize("name", EXACT)
@pytest.mark.parametrize("preset", ["female", "male"])
def test_every_expression_of_a_sequence_has_the_objective_of_the_plain_model(name: str, preset: str):
    loaded = available(name)
    rig = rigs.generate(preset)
    analysis = packing.analyse(rig, rigs.warp(rig, "alien").neutral)
    grown = packing.sequence(rig, loaded, analysis=analysis, jmax=12)
    plain = packing.sequence(rig, _plain(name), analysis=analysis, jmax=12)
    packing.check(rig, grown, pairs=analysis.pairs)
    assert [e.items for e in grown] == [e.items for e in plain]
    assert [e.objective for e in grown] == [e.objective for e in plain]


@pytest.mark.parametrize("cap", [3, None])
def test_a_capped_sequence_has_the_objectives_of_the_plain_model(cap):
    rig = rigs.generate("female")
    analysis = packing.analyse(rig, rigs.warp(rig, "alien").neutral, max_per_expression=cap)
    grown = packing.sequence(rig, solvers.get("cpsat"), analysis=analysis)
    plain = packing.sequence(rig, _plain("cpsat"), analysis=analysis)
    packing.check(rig, grown, pairs=analysis.pairs, max_per_expression=cap)
    assert [e.objective for e in grown] == [e.objective for e in plain]


def _grown_by_visiting(model, conflicts: np.ndarray) -> list[tuple[int, ...]]:
    """Each row grown by visiting the items by decreasing weight (ties by index), one at a time."""
    order = np.argsort(-model.weights, kind="stable").tolist()
    rows = set()
    for r in range(model.n_rows):
        row = set(model.row(r).tolist())
        for item in order:
            if item not in row and all(conflicts[item, member] for member in row):
                row.add(item)
        rows.add(tuple(sorted(row)))
    return sorted(rows)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 100_000), cap=st.sampled_from([None, 3]), n_items=st.integers(12, 90))
def test_grown_rows_are_the_rows_grown_one_item_at_a_time_by_weight(seed, cap, n_items):
    problem = random_problem(n_items, 3 * n_items, seed=seed, active=(2, 10), cap=cap)
    reduction = reduce_problem(problem, cap is not None)
    closed = kernel_neighbourhoods(problem.conflict_bits, reduction.kept, problem.n_items)
    model = reduction.cut_model()
    grown = grown_cliques(model, closed)
    rows = [tuple(grown.row(r).tolist()) for r in range(grown.n_rows)]
    assert sorted(rows) == _grown_by_visiting(model, _conflicts(closed, model.n_items))


def _row_pairs(model) -> set[tuple[int, int]]:
    return {pair for r in range(model.n_rows) for pair in itertools.combinations(model.row(r).tolist(), 2)}


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 100_000), cap=st.sampled_from([None, 3]), drops=st.integers(1, 3))
def test_the_cut_rows_of_a_restricted_problem_are_its_kernels_conflicts(seed, cap, drops):
    """Along a sequence the rows come from an earlier problem's conflict sets (`conflict_view`): they are
    cliques of the kernel and cover each of its conflicting pairs, so the packings are the kernel's; the
    restricted problem's own maximal sets are not derived."""
    problem = random_problem(40, 90, seed=seed, active=(2, 8), cap=cap)
    rng = np.random.default_rng(seed)
    for _ in range(drops):  # a chain of restrictions, as `Analysis.next_problem` makes, each problem's bits
        assert problem.conflict_bits.shape[0] == problem.n_items  # derived from its parent's (read first)
        problem = problem.restrict(np.sort(rng.choice(problem.n_items, problem.n_items - 3, replace=False)))
    reduction = reduce_problem(problem, cap is not None)
    model = reduction.cut_model()
    assert not problem._lineage().known
    closed = kernel_neighbourhoods(problem.conflict_bits, reduction.kept, problem.n_items)
    conflicts = _conflicts(closed, reduction.kept.size)
    assert _row_pairs(model) == {(a, b) for a, b in zip(*np.nonzero(np.triu(conflicts)), strict=True)}
    assert np.array_equal(model.weights, np.asarray(problem.weights)[reduction.kept])
    assert np.array_equal(model.shape_counts, problem.item_shape_counts[reduction.kept])
    assert model.cap == reduction.model.cap
