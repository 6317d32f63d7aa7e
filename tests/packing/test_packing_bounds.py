"""Bounds on the fewest expressions (largest conflict clique, greedy colouring) against the sequence."""

from __future__ import annotations

import numpy as np
import pytest

import packing
from packing import problem_from_incidence


def _chain_problem(weights):
    # a-b-c-d: a and b share vertex 0, b and c vertex 1, c and d vertex 2; a and d own one more each.
    incidence = np.array(
        [
            [1, 0, 0, 1, 0],
            [1, 1, 0, 0, 0],
            [0, 1, 1, 0, 0],
            [0, 0, 1, 0, 1],
        ],
        dtype=bool,
    )
    return problem_from_incidence(incidence, weights, shape_names=("a", "b", "c", "d"))


def test_chain_needs_two_but_the_sequence_takes_three(kit):
    problem = _chain_problem([1.0, 0.6, 0.6, 1.0])  # {a, d} is the heaviest first expression
    bound = packing.expression_lower_bound(problem)
    assert (bound.lower, bound.upper) == (2, 2)
    assert len(bound.clique) == 2
    rounds, remaining = 0, list(range(problem.n_items))
    solver = kit.ExactSolver()
    while remaining:
        sub = problem.restrict(remaining)
        chosen = solver.solve(sub).items
        remaining = [r for i, r in enumerate(remaining) if i not in chosen]
        rounds += 1
    assert rounds == 3 > bound.lower


def test_clique_is_the_largest_pairwise_conflict_not_a_vertex_set():
    # Three items pairwise overlapping at three different vertices: no vertex holds all three.
    incidence = np.array([[1, 1, 0], [0, 1, 1], [1, 0, 1]], dtype=bool)
    problem = problem_from_incidence(incidence, [1.0, 1.0, 1.0])
    assert max(len(c) for c in problem.cliques) == 2
    assert packing.expression_lower_bound(problem).lower == 3


def test_cap_raises_the_lower_bound():
    problem = problem_from_incidence(np.eye(6, dtype=bool), np.ones(6), cap=4)
    bound = packing.expression_lower_bound(problem)
    assert (bound.lower, bound.upper) == (2, 2)


def test_item_larger_than_the_cap_is_refused():
    problem = problem_from_incidence(np.eye(2, dtype=bool), np.ones(2), items=((0, 1), (2,)), cap=1)
    with pytest.raises(ValueError, match=r"item 's0\+s1' has 2 shapes, more than the cap 1"):
        packing.expression_lower_bound(problem)


def test_bound_brackets_the_sequence_on_a_face(face, exact_solver):
    rig, _ = face
    analysis = packing.analyse(rig, rig.neutral)
    bound = packing.expression_lower_bound(analysis)
    count = len(packing.sequence(rig, exact_solver, analysis=analysis))
    assert bound.lower <= count
    assert bound.lower <= bound.upper
