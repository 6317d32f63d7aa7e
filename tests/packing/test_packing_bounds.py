"""Bounds on the fewest expressions (largest conflict clique, greedy colouring) against the sequence."""

from __future__ import annotations

import networkx as nx
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

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


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    n_items=st.integers(2, 40),
    density=st.floats(0.05, 0.6),
    apart=st.integers(0, 5),
)
def test_the_clique_bound_is_the_clique_number_and_the_colouring_covers(seed, n_items, density, apart):
    rng = np.random.default_rng(seed)
    incidence = rng.random((n_items, 30)) < density / 4
    incidence[np.arange(n_items), rng.integers(0, 30, n_items)] = True
    pairs = {tuple(sorted(rng.choice(n_items, 2, replace=False).tolist())) for _ in range(apart)}
    problem = problem_from_incidence(incidence, np.ones(n_items), apart=sorted(pairs))
    graph = nx.Graph()
    graph.add_nodes_from(range(n_items))
    overlaps = (incidence.astype(int) @ incidence.T.astype(int)) > 0
    graph.add_edges_from((a, b) for a in range(n_items) for b in range(a + 1, n_items) if overlaps[a, b])
    graph.add_edges_from(pairs)
    bound = packing.expression_lower_bound(problem)
    assert bound.lower == max(len(c) for c in nx.find_cliques(graph))
    labels = set(bound.clique)
    members = [i for i in range(n_items) if problem.item_label(i) in labels]
    assert len(members) == bound.lower and all(
        graph.has_edge(a, b) for a in members for b in members if a < b
    )
    colour = packing.first_fit_colouring(problem)
    assert bound.lower <= bound.upper == len(set(colour.tolist()))
    assert all(colour[a] != colour[b] for a, b in graph.edges)
