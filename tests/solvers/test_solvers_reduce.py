"""The exact reductions every exact backend applies before it builds its model (`solvers._reduce`), the CP-SAT
model written straight into its proto, and the strict greedy on conflict sets: each equivalent to its plain
definition."""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import packing
import rigs
import solvers
from packing import problem_from_incidence
from solvers._cpsat_run import integer_weights
from solvers._model import CliqueModel
from solvers._reduce import reduce_problem
from solvers.cpsat import _model_proto
from solvers.greedy import greedy_items
from solvers.testing import brute_force_optimum, face_like_problem, random_problem


def _problem(seed: int, cap: int | None, apart: int) -> packing.PackingProblem:
    rng = np.random.default_rng(seed)
    base = random_problem(int(rng.integers(4, 17)), 24, seed=seed, active=(1, 6), cap=cap)
    pairs = {tuple(sorted(rng.choice(base.n_items, 2, replace=False).tolist())) for _ in range(apart)}
    return problem_from_incidence(
        base.incidence, base.weights, items=base.items, cap=cap, apart=sorted(pairs)
    )


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 100_000), cap=st.sampled_from([None, 2, 3, 5]), apart=st.integers(0, 3))
def test_reductions_keep_the_optimum(seed, cap, apart):
    problem = _problem(seed, cap, apart)
    cap_binds = cap is not None and cap < int(problem.item_shape_counts.sum())
    reduction = reduce_problem(problem, cap_binds)
    value, optimum = brute_force_optimum(problem)
    assert set(reduction.taken.tolist()) <= set(optimum)  # in every optimal packing
    assert set(optimum) <= set(reduction.kept.tolist()) | set(reduction.taken.tolist())  # none dominated
    kernel = problem.restrict(reduction.kept)
    kernel_value, kernel_items = brute_force_optimum(kernel)
    assert reduction.items(kernel_items) == optimum
    assert kernel_value + problem.weights[reduction.taken].sum() == pytest.approx(value, rel=1e-12)
    model = reduction.model
    assert model.n_items == kernel.n_items and np.array_equal(model.weights, kernel.weights)
    rows = [model.row(r).tolist() for r in range(model.n_rows)]
    assert rows == [c.tolist() for c in kernel.cliques]


def test_tied_weights_keep_every_optimal_value():
    """Strict domination only: items of equal weight are never removed for each other."""
    incidence = np.array([[1, 1, 0, 0], [0, 1, 1, 0], [0, 0, 1, 1], [1, 0, 0, 1], [1, 1, 1, 1]])
    problem = problem_from_incidence(incidence, np.ones(5))
    reduction = reduce_problem(problem, cap_binds=False)
    assert set(range(4)) <= set(reduction.kept.tolist())  # the ring survives; item 4 conflicts with all
    for name in ("cpsat", "highs"):
        assert solvers.get(name).solve(problem).objective == pytest.approx(2.0)


@pytest.mark.parametrize("name", ["cpsat", "highs"])
@pytest.mark.parametrize("seed", range(4))
def test_reduced_and_full_models_give_the_same_packings(monkeypatch, name, seed):
    solver = solvers.get(name)
    problems = [face_like_problem(120, 1600, seed=seed), face_like_problem(60, 900, seed=seed, cap=8)]
    reduced = [solver.solve(problem) for problem in problems]
    monkeypatch.setattr(type(solver.plugin), "reduces", False)
    full = [solver.solve(problem) for problem in problems]
    for with_reductions, without in zip(reduced, full, strict=True):
        assert with_reductions.termination is without.termination is packing.Termination.OPTIMAL
        assert with_reductions.items == without.items
        assert with_reductions.objective == without.objective


def test_reduced_sequence_equals_the_full_one_on_a_preset(monkeypatch):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", packing.MissingTargetWarning)
        rig = rigs.generate("digidouble")
        analysis = packing.analyse(rig)
    solver = solvers.get("cpsat")
    reduced = packing.sequence(rig, solver, analysis=analysis)
    monkeypatch.setattr(type(solver.plugin), "reduces", False)
    full = packing.sequence(rig, solver, analysis=analysis)
    assert [e.items for e in reduced] == [e.items for e in full]
    assert [e.objective for e in reduced] == [e.objective for e in full]
    assert [e.bound for e in reduced] == pytest.approx([e.bound for e in full], rel=1e-12)


def _public_proto(model: CliqueModel) -> str:
    """The model as `cp_model.CpModel` writes it, as text without variable names."""
    from ortools.sat.python import cp_model

    scaled, _ = integer_weights(model.weights)
    built = cp_model.CpModel()
    chosen = [built.new_bool_var(f"x{i}") for i in range(model.n_items)]
    for r in range(model.n_rows):
        built.add_at_most_one(chosen[i] for i in model.row(r).tolist())
    if model.cap is not None:
        built.add(cp_model.LinearExpr.weighted_sum(chosen, model.shape_counts.tolist()) <= model.cap)
    built.maximize(cp_model.LinearExpr.weighted_sum(chosen, scaled.tolist()))
    return re.sub(r"\s+", " ", re.sub(r'name: "x\d+"', "", str(built.proto))).strip()


@pytest.mark.parametrize("cap", [None, 3])
@pytest.mark.parametrize("seed", range(5))
def test_cpsat_proto_is_the_model_cp_model_builds(cap, seed):
    from ortools.sat.python import cp_model_helper

    model = CliqueModel.from_problem(random_problem(14, 40, seed=seed, cap=cap))
    assert (model.cap is None) == (cap is None)
    written = re.sub(r"\s+", " ", str(_model_proto(cp_model_helper, model))).strip()
    assert written == _public_proto(model)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 100_000), cap=st.sampled_from([None, 2, 4]), apart=st.integers(0, 3))
def test_strict_greedy_on_conflict_sets_equals_greedy_on_vertices(seed, cap, apart):
    """Overlap 0 runs on the conflict sets; a vanishing allowed overlap runs the vertex-by-vertex loop."""
    problem = _problem(seed, cap, apart)
    assert greedy_items(problem, 0.0) == greedy_items(problem, 1e-12)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 100_000), cap=st.sampled_from([None, 2, 4]), apart=st.integers(0, 3))
def test_strict_greedy_down_a_sequence_of_restrictions_equals_greedy_on_vertices(seed, cap, apart):
    """Each restricted problem of a sequence reads its first ancestor's sets through their neighbour
    lists (made once, for the whole lineage): the same items as the vertex loop at every step."""
    problem = _problem(seed, cap, apart)
    lineage = problem.conflict_view.sets
    while problem.n_items:
        chosen = greedy_items(problem, 0.0)
        assert chosen and chosen == greedy_items(problem, 1e-12)
        assert problem.conflict_view.sets is lineage
        problem = problem.restrict(np.setdiff1d(np.arange(problem.n_items), chosen))
