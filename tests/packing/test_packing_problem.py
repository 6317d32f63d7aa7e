"""build_problem: items, merged pairs, weights, exclusions, cap, and the tie-break perturbation."""

from __future__ import annotations

import itertools
import warnings

import numpy as np
import pytest

import packing
from packing import tie_break_perturbation


@pytest.fixture(autouse=True)
def _quiet():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", packing.MissingTargetWarning)
        yield


def test_pairs_are_one_item_with_union_and_summed_weight(face):
    rig, truth = face
    analysis = packing.analyse(rig)
    problem = analysis.problem
    masks = packing.binary_blendshapes(rig.deltas)
    weights = packing.importance(rig)
    labels = [problem.item_label(i) for i in range(problem.n_items)]
    for left, right in truth["mirror_pairs"] + truth["motion_pairs"]:
        a, b = rig.index(left), rig.index(right)
        item = problem.items.index((min(a, b), max(a, b)))
        assert problem.incidence[item].toarray().ravel().tolist() == (masks[a] | masks[b]).tolist()
        assert problem.unperturbed_objective([item]) == pytest.approx(weights[a] + weights[b])
    assert "empty" not in "+".join(labels)
    assert sum(problem.item_shape_counts) == rig.n_shapes - 1
    assert problem.n_vertex_rows == int(masks.any(axis=0).sum())
    assert len(problem.cliques) <= problem.n_vertex_rows


def test_build_problem_equals_the_analysis_problem(face):
    rig, _ = face
    built = packing.build_problem(rig, rig.neutral * [1.2, 1, 1], mu=0.35, max_per_expression=5)
    analysis = packing.analyse(rig, rig.neutral * [1.2, 1, 1], mu=0.35, max_per_expression=5)
    assert built.items == analysis.problem.items
    assert built.weights.tolist() == analysis.problem.weights.tolist()
    assert built.cap == 5
    assert built.meta["params"]["mu"] == 0.35


def test_excluded_shapes_remove_their_whole_item(face):
    rig, _ = face
    problem = packing.build_problem(rig, exclude=["browUp_L", "noseWrinkle"])
    shapes = {rig.names[k] for item in problem.items for k in item}
    assert not shapes & {"browUp_L", "browUp_R", "noseWrinkle"}
    assert problem.meta["excluded"] == ("browUp_L", "noseWrinkle")


def test_cap_of_one_cannot_hold_a_pair(face):
    rig, _ = face
    said = r"\(max_per_expression=1, --cap 1\) cannot hold the symmetry pair \w+\+\w+ .*--no-symmetry"
    with pytest.raises(ValueError, match=said):
        packing.build_problem(rig, max_per_expression=1)
    assert packing.build_problem(rig, max_per_expression=1, symmetry=False).cap == 1


@pytest.mark.parametrize("cap", [0, -2, 1.5, True])
def test_bad_cap_is_named(face, cap):
    rig, _ = face
    with pytest.raises(
        ValueError, match=f"max_per_expression must be a positive integer or None, got {cap!r}"
    ):
        packing.build_problem(rig, max_per_expression=cap)


def test_uniqueness_reweights_without_new_presolve(face):
    rig, _ = face
    analysis = packing.analyse(rig, beta=1.0)
    used = ["jawForward"]
    problem = analysis.problem_for(used)
    assert problem.meta["item_index"].size == analysis.problem.n_items - 1
    expected = analysis.item_shapes @ packing.importance(rig, beta=1.0, used=used)
    assert problem.weights == pytest.approx(expected[problem.meta["item_index"]] + problem.tie_break)
    narrowed = problem.restrict([0, 2])  # e.g. artist refinement on top: the map to analysis items follows
    assert narrowed.items == tuple(analysis.problem.items[i] for i in narrowed.meta["item_index"])


LABELS = [f"shape{k:03d}" for k in range(265)] + [f"pairL{k}+pairR{k}" for k in range(20)]


def test_tie_break_depends_on_names_not_order():
    eps = dict(zip(LABELS, tie_break_perturbation(LABELS), strict=True))
    shuffled = list(np.random.default_rng(0).permutation(LABELS))
    assert dict(zip(shuffled, tie_break_perturbation(shuffled), strict=True)) == eps
    values = np.array(list(eps.values()))
    assert len(set(values.tolist())) == len(values)
    assert (values > 0).all() and (values < packing._analysis.TIE_BREAK_SCALE).all()


def test_tie_break_separates_small_exchanges_above_solver_tolerance():
    eps = tie_break_perturbation(LABELS)
    scale, n = packing._analysis.TIE_BREAK_SCALE, len(LABELS)
    ordered = np.sort(eps)
    assert np.diff(ordered).min() >= 0.75 * scale / (n + 1)  # one item for another
    rng = np.random.default_rng(1)
    rank = np.argsort(np.argsort(eps))
    for size in (2, 3):
        for _ in range(3000):
            picked = rng.choice(n, size=2 * size, replace=False)
            out, into = picked[:size], picked[size:]
            if rank[out].sum() == rank[into].sum():
                continue
            assert abs(eps[out].sum() - eps[into].sum()) >= scale / (4 * (n + 1)) > 1e-9


def test_tie_break_never_changes_the_number_of_shapes_without_importance():
    eps = tie_break_perturbation(LABELS)
    assert eps.sum() < 1.0  # one more shape (weight 1) always beats any perturbation


def test_tie_break_makes_the_optimum_unique(kit):
    # Four identical shapes on disjoint vertices plus a chain: many tied optima without the perturbation.
    bumps = [kit.Bump(f"dot{k}", (-0.6 + 0.4 * k, 0.5), (0.05, 0.05), (0, 0, 1.0)) for k in range(4)]
    bumps += [kit.Bump(f"bar{k}", (-0.6 + 0.2 * k, -0.5), (0.12, 0.05), (0, 0, 1.0)) for k in range(6)]
    rig = kit.face_rig(bumps, regions={})
    problem = packing.build_problem(rig, importance=False, symmetry=False)
    values = sorted(
        (problem.objective(s), s)
        for r in range(problem.n_items + 1)
        for s in itertools.combinations(range(problem.n_items), r)
        if problem.incidence[list(s)].toarray().sum(axis=0).max(initial=0) <= 1
    )
    best, runner_up = values[-1], values[-2]
    assert round(best[0]) == round(runner_up[0])  # a genuine tie in the number of shapes ...
    assert best[0] - runner_up[0] > 1e-9  # ... broken by more than the solvers' tolerance


@pytest.mark.parametrize("seed", [0, 1])
def test_permuted_problem_has_the_same_optimum_mapped_back(seed):
    import solvers
    from solvers.testing import brute_force_optimum, check_packing, conformance_problems

    cpsat = solvers.get("cpsat")
    for name, problem in conformance_problems(seed):
        order = np.random.default_rng(seed).permutation(problem.n_items)
        permuted = problem.permuted(order)
        rebuilt = packing.problem_from_incidence(
            problem.incidence[order], problem.weights[order], items=permuted.items, cap=problem.cap,
            apart=permuted.apart, shape_names=problem.shape_names,
        )  # fmt: skip
        assert {tuple(c) for c in permuted.cliques} == {tuple(c) for c in rebuilt.cliques}, name
        assert permuted.n_vertex_rows == problem.n_vertex_rows
        assert brute_force_optimum(permuted)[0] == pytest.approx(brute_force_optimum(problem)[0], rel=1e-12)
        solution = cpsat.solve(permuted, seed=0)
        back = sorted(int(order[i]) for i in solution.items)
        check_packing(problem, back)
        assert problem.objective(back) == pytest.approx(brute_force_optimum(problem)[0], rel=1e-9), name


def test_permuted_rejects_a_non_permutation():
    from solvers.testing import conformance_problems

    problem = conformance_problems(0)[0][1]
    with pytest.raises(ValueError, match="permutation"):
        problem.permuted([0] * problem.n_items)
