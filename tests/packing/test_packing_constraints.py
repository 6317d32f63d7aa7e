"""Artist constraints (together / apart pairs): parsing, the problem they make, the sequence, the checker."""

from __future__ import annotations

import json

import numpy as np
import pytest

import packing
import solvers
from solvers.testing import brute_force_optimum, check_packing


def _as_sets(pairs):
    return {frozenset(pair) for pair in pairs}


# -- parsing ----------------------------------------------------------------------------------------------


def test_parse_pair_takes_two_distinct_names():
    assert packing.parse_pair(" eyeLookOut_L , eyeLookIn_R ") == ("eyeLookOut_L", "eyeLookIn_R")
    for bad in ("a", "a,b,c", ",b", "a,", "a,a"):
        with pytest.raises(ValueError, match="is not a pair of shape names|pairs a shape with itself"):
            packing.parse_pair(bad)


def test_params_normalise_pairs_and_refuse_bad_ones():
    params = packing.PackingParams(together=["a,b", ("c", "d"), "a,b"], apart=[["e", "f"]])
    assert params.together == (("a", "b"), ("c", "d"))
    assert params.apart == (("e", "f"),)
    assert params.as_dict()["together"] == [["a", "b"], ["c", "d"]]
    with pytest.raises(ValueError, match="together"):
        packing.PackingParams(together="a,b")
    with pytest.raises(ValueError, match="apart: entry"):
        packing.PackingParams(apart=[("a", "b", "c")])


def test_read_constraints_names_the_file_and_the_fault(tmp_path):
    good = tmp_path / "constraints.json"
    good.write_text(json.dumps({"together": [["a", "b"]], "apart": ["c,d"]}))
    assert packing.read_constraints(good) == {"together": (("a", "b"),), "apart": (("c", "d"),)}
    cases = {
        "missing.json": None,
        "broken.json": "{",
        "list.json": "[]",
        "unknown.json": json.dumps({"together": [], "near": []}),
        "bad-entry.json": json.dumps({"apart": [["a"]]}),
    }
    for name, text in cases.items():
        path = tmp_path / name
        if text is not None:
            path.write_text(text)
        with pytest.raises(ValueError, match=name):
            packing.read_constraints(path)


# -- analysis and problem -------------------------------------------------------------------------------


def test_unknown_names_get_a_did_you_mean(face):
    rig, _ = face
    with pytest.raises(ValueError, match="did you mean browUp_L"):
        packing.analyse(rig, rig.neutral, apart=[("browUpL", "browUp_R")])


def test_contradictions_are_refused(face):
    rig, _ = face
    with pytest.raises(ValueError, match="both a together and an apart pair"):
        packing.analyse(rig, rig.neutral, together=["browUp_L,jawForward"], apart=["jawForward,browUp_L"])
    with pytest.raises(ValueError, match="two together pairs"):
        packing.analyse(rig, rig.neutral, together=["browUp_L,jawForward", "browUp_L,noseWrinkle"])
    with pytest.raises(ValueError, match="empty is empty"):
        packing.analyse(rig, rig.neutral, together=["browUp_L,empty"])


def test_together_pair_replaces_the_symmetry_pairs_of_its_shapes(face):
    rig, truth = face
    analysis = packing.analyse(rig, rig.neutral, together=[("browUp_L", "mouthSmile_R")])
    assert ("browUp_L", "mouthSmile_R") in analysis.pairs
    assert not _as_sets(analysis.pairs) & {
        frozenset(("browUp_L", "browUp_R")),
        frozenset(("mouthSmile_L", "mouthSmile_R")),
    }
    labels = {analysis.problem.item_label(i) for i in range(analysis.problem.n_items)}
    assert "browUp_L+mouthSmile_R" in labels and "browUp_R" in labels


def test_apart_pair_drops_a_detected_pair_and_becomes_a_conflict(face):
    rig, truth = face
    analysis = packing.analyse(
        rig, rig.neutral, apart=[("browUp_L", "browUp_R"), ("jawForward", "noseWrinkle")]
    )
    assert frozenset(("browUp_L", "browUp_R")) not in _as_sets(analysis.pairs)
    assert any("kept apart by the artist" in note for note in analysis.notes)
    problem = analysis.problem
    index = {problem.item_label(i): i for i in range(problem.n_items)}
    apart = {frozenset(pair) for pair in problem.apart}
    assert frozenset((index["jawForward"], index["noseWrinkle"])) in apart
    assert any(
        {index["jawForward"], index["noseWrinkle"]} <= set(clique.tolist()) for clique in problem.cliques
    )


def test_apart_items_follow_restriction():
    incidence = np.eye(4, dtype=bool)
    problem = packing.problem_from_incidence(incidence, [1.0, 2.0, 3.0, 4.0], apart=[(3, 1), (0, 2)])
    assert problem.apart == ((0, 2), (1, 3))
    assert sorted(map(sorted, (c.tolist() for c in problem.cliques))) == [[0, 2], [1, 3]]
    restricted = problem.restrict([1, 2, 3])
    assert restricted.apart == ((0, 2),)
    with pytest.raises(ValueError, match="apart pairs"):
        packing.problem_from_incidence(incidence, [1.0] * 4, apart=[(1, 1)])


@pytest.mark.parametrize("name", ["cpsat", "highs", "cbc-pulp", "greedy", "greedy-overlap", "naive-pulp-cbc"])
def test_every_backend_keeps_apart_items_apart(name):
    found = solvers.availability(name)
    if not found:
        pytest.skip(found.reason)
    solver = solvers.get(name)
    # Four disjoint items: without the apart pairs every solver takes them all.
    incidence = np.kron(np.eye(4, dtype=bool), np.ones((1, 12), dtype=bool))
    problem = packing.problem_from_incidence(incidence, [0.9, 0.8, 0.7, 0.6], apart=[(0, 1), (2, 3)])
    solution = solver.solve(problem, seed=0)
    check_packing(problem, solution.items)
    assert len(solution.items) == 2
    if solver.capabilities.exact:
        assert problem.objective(solution.items) == pytest.approx(brute_force_optimum(problem)[0])


# -- sequence and checker -------------------------------------------------------------------------------


def test_sequence_honours_both_kinds_and_the_checker_verifies_them(face, exact_solver):
    rig, _ = face
    constraints = {"together": [("jawForward", "browDown_R")], "apart": [("browUp_L", "noseWrinkle")]}
    expressions = packing.sequence(rig, exact_solver, target_neutral=rig.neutral, **constraints)
    holding = {name: e.index for e in expressions for name in e.shapes}
    assert holding["jawForward"] == holding["browDown_R"]
    assert holding["browUp_L"] != holding["noseWrinkle"]
    packing.check(rig, expressions, maximal=True, **constraints)

    with pytest.raises(packing.CheckError) as split:
        packing.check(
            rig, [["jawForward"], ["browDown_R"]], pairs=[], together=[("jawForward", "browDown_R")]
        )
    assert split.value.kind == "together"
    with pytest.raises(packing.CheckError) as joined:
        packing.check(rig, [["browUp_L", "noseWrinkle"]], pairs=[], apart=[("browUp_L", "noseWrinkle")])
    assert joined.value.kind == "apart"


def test_extra_examples_respect_apart_pairs(face, exact_solver):
    rig, _ = face
    free = packing.sequence(rig, exact_solver, target_neutral=rig.neutral, extra_examples=True)
    extras = [(e.index, name) for e in free for name in e.extra_examples]
    assert extras, "the face rig must have extra examples for this test to mean anything"
    index, extra = extras[0]
    primary = next(e for e in free if e.index == index).shapes[0]
    constrained = packing.sequence(
        rig, exact_solver, target_neutral=rig.neutral, extra_examples=True, apart=[(primary, extra)]
    )
    for expression in constrained:
        assert not {primary, extra} <= set(expression.shapes + expression.extra_examples)
    packing.check(rig, constrained, apart=[(primary, extra)])
