"""The presolve to maximal conflict sets keeps exactly the feasible set of the per-vertex model (eq. 3b)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings, strategies as st

from packing import problem_from_incidence
from packing._presolve import ConflictSets, maximal_conflict_sets


@st.composite
def instances(draw):
    """Random shapes over a few vertices, some merged into pair items, random weights, maybe a cap."""
    n_shapes = draw(st.integers(1, 8))
    n_vertices = draw(st.integers(1, 10))
    masks = np.array(
        draw(
            st.lists(
                st.lists(st.booleans(), min_size=n_vertices, max_size=n_vertices),
                min_size=n_shapes,
                max_size=n_shapes,
            )
        )
    )
    order = draw(st.permutations(range(n_shapes)))
    n_pairs = draw(st.integers(0, n_shapes // 2))
    items = [tuple(sorted(order[2 * p : 2 * p + 2])) for p in range(n_pairs)]
    items += [(k,) for k in order[2 * n_pairs :]]
    items.sort()
    incidence = np.array([masks[list(item)].any(axis=0) for item in items])
    weights = np.array(draw(st.lists(st.floats(0.0, 2.0), min_size=len(items), max_size=len(items))))
    cap = draw(st.none() | st.integers(1, n_shapes))
    return incidence, weights, tuple(items), cap


def _feasible_per_vertex(incidence, chosen, sizes, cap):
    if cap is not None and sizes[list(chosen)].sum() > cap:
        return False
    return incidence[list(chosen)].sum(axis=0).max(initial=0) <= 1


def _feasible_presolved(problem, chosen):
    if problem.cap is not None and problem.item_shape_counts[list(chosen)].sum() > problem.cap:
        return False
    members = set(chosen)
    return all(len(members.intersection(clique.tolist())) <= 1 for clique in problem.cliques)


def _subsets(n):
    return itertools.chain.from_iterable(itertools.combinations(range(n), r) for r in range(n + 1))


@settings(max_examples=150, deadline=None)
@given(instances())
def test_presolve_keeps_the_feasible_set_and_the_optimum(instance):
    incidence, weights, items, cap = instance
    problem = problem_from_incidence(incidence, weights, items=items, cap=cap)
    sizes = problem.item_shape_counts
    by_vertex = {s for s in _subsets(len(items)) if _feasible_per_vertex(incidence, s, sizes, cap)}
    by_clique = {s for s in _subsets(len(items)) if _feasible_presolved(problem, s)}
    assert by_vertex == by_clique
    best = max(weights[list(s)].sum() for s in by_vertex)
    assert max(problem.objective(s) for s in by_clique) == pytest.approx(best)


@settings(max_examples=150, deadline=None)
@given(instances(), st.data())
def test_restricted_presolve_equals_presolving_from_the_vertices(instance, data):
    incidence, weights, items, cap = instance
    problem = problem_from_incidence(incidence, weights, items=items, cap=cap)
    keep = sorted(data.draw(st.sets(st.integers(0, len(items) - 1))))
    restricted = problem.restrict(keep)
    fresh = problem_from_incidence(
        incidence[keep], weights[keep], items=tuple(items[i] for i in keep), cap=cap
    )
    assert [c.tolist() for c in restricted.cliques] == [c.tolist() for c in fresh.cliques]
    assert restricted.n_vertex_rows == fresh.n_vertex_rows
    assert restricted.items == fresh.items
    assert restricted.weights.tolist() == fresh.weights.tolist()


def _naive_maximal_sets(incidence):
    """The definition, by Python sets: distinct vertex item sets of size >= 2 that lie in no other."""
    sets = {frozenset(np.flatnonzero(column).tolist()) for column in np.asarray(incidence, dtype=bool).T}
    sets = {s for s in sets if len(s) >= 2}
    maximal = [sorted(s) for s in sets if not any(s < other for other in sets)]
    return sorted(maximal, key=lambda items: (-len(items), items))


@settings(max_examples=200, deadline=None)
@given(instances())
def test_presolve_gives_the_maximal_vertex_sets_in_canonical_order(instance):
    incidence = instance[0]
    cliques, rows = maximal_conflict_sets(sp.csr_matrix(incidence))
    assert [c.tolist() for c in cliques] == _naive_maximal_sets(incidence)
    assert rows == int(incidence.any(axis=0).sum())


@st.composite
def wide_instances(draw):
    """Up to 140 items (three 64-bit words) on up to 60 vertices, each item on a few nearby vertices."""
    n_items = draw(st.integers(2, 140))
    n_vertices = draw(st.integers(2, 60))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    centre = rng.integers(0, n_vertices, size=n_items)
    spread = rng.integers(0, 4, size=n_items)
    vertex = np.arange(n_vertices)
    incidence = np.abs(vertex[None, :] - centre[:, None]) <= spread[:, None]
    incidence &= rng.random(incidence.shape) < draw(st.floats(0.5, 1.0))
    return incidence


@settings(max_examples=100, deadline=None)
@given(wide_instances())
def test_presolve_of_many_items_gives_the_maximal_vertex_sets(incidence):
    cliques, _ = maximal_conflict_sets(sp.csr_matrix(incidence))
    assert [c.tolist() for c in cliques] == _naive_maximal_sets(incidence)


@settings(max_examples=100, deadline=None)
@given(wide_instances(), st.data())
def test_a_chain_of_restrictions_equals_presolving_from_the_vertices(incidence, data):
    """The expression sequence restricts the previous problem again and again (incremental presolve)."""
    n_items = incidence.shape[0]
    weights = np.linspace(0.1, 1.0, n_items)
    problem = problem_from_incidence(incidence, weights)
    alive = np.arange(n_items)  # items of the first problem still in `problem`
    for _ in range(data.draw(st.integers(1, 6))):
        if problem.n_items == 0:
            break
        most = max(1, problem.n_items // 3)
        dropped = data.draw(st.sets(st.integers(0, problem.n_items - 1), max_size=most))
        keep = [i for i in range(problem.n_items) if i not in dropped]
        problem, alive = problem.restrict(keep), alive[keep]
        fresh = problem_from_incidence(incidence[alive], weights[alive])
        assert [c.tolist() for c in problem.cliques] == [c.tolist() for c in fresh.cliques]
        assert [c.tolist() for c in problem.cliques] == _naive_maximal_sets(incidence[alive])
        assert problem.n_vertex_rows == fresh.n_vertex_rows
        assert (problem.incidence != fresh.incidence).nnz == 0
        assert problem.weights.tolist() == weights[alive].tolist()


def restrict_conflict_sets(cliques, keep, n_items):
    """The maximal conflict sets of the sub-problem over the items ``keep`` (`ConflictSets.restrict`)."""
    kept = np.zeros(n_items, dtype=bool)
    kept[keep] = True
    return ConflictSets.from_cliques(cliques, n_items).restrict(kept).as_tuple()


def test_restrict_keeps_one_of_equal_sets_and_drops_the_contained_ones():
    cliques = (np.array([0, 1, 2]), np.array([0, 1, 3]), np.array([2, 3, 4]))
    assert [c.tolist() for c in restrict_conflict_sets(cliques, np.array([0, 1, 4]), 5)] == [[0, 1]]
    assert [c.tolist() for c in restrict_conflict_sets(cliques, np.array([0, 1, 2, 4]), 5)] == [
        [0, 1, 2],
        [2, 3],
    ]
    assert [c.tolist() for c in restrict_conflict_sets(cliques, np.arange(5), 5)] == [
        [0, 1, 2],
        [0, 1, 3],
        [2, 3, 4],
    ]


def test_explicit_zeros_and_duplicate_entries_are_not_active_vertices():
    # Item 0 on vertices 0, 1; item 1 on vertex 1 (stored twice) and an explicit zero at vertex 0.
    incidence = sp.csr_matrix(
        (np.array([1, 1, 0, 1, 1]), (np.array([0, 0, 1, 1, 1]), np.array([0, 1, 0, 1, 1]))), shape=(2, 3)
    )
    stored = incidence.copy()
    cliques, rows = maximal_conflict_sets(incidence)
    assert [c.tolist() for c in cliques] == [[0, 1]] and rows == 2
    assert (incidence != stored).nnz == 0 and incidence.nnz == stored.nnz  # the caller's matrix is untouched
    problem = problem_from_incidence(incidence, [1.0, 1.0])
    assert problem.item_active_counts.tolist() == [2, 1]
    assert problem.restrict([1]).n_vertex_rows == 1


def test_rows_before_and_after():
    # Vertices: 0 in {0}, 1 in {0, 1}, 2 in {0, 1, 2}, 3 in {1, 2}, 4 in {2, 3}, 5 in {2, 3}, 6 in none.
    incidence = np.zeros((4, 7), dtype=bool)
    for vertex, members in enumerate([{0}, {0, 1}, {0, 1, 2}, {1, 2}, {2, 3}, {2, 3}, set()]):
        incidence[list(members), vertex] = True
    cliques, rows = maximal_conflict_sets(sp.csr_matrix(incidence))
    assert rows == 6
    assert [c.tolist() for c in cliques] == [[0, 1, 2], [2, 3]]


def test_restrict_drops_singletons_and_dominated_sets():
    cliques = (np.array([0, 1, 2]), np.array([2, 3]), np.array([1, 3]))
    assert [c.tolist() for c in restrict_conflict_sets(cliques, np.array([1, 2, 3]), 4)] == [
        [0, 1],
        [0, 2],
        [1, 2],
    ]
    assert restrict_conflict_sets(cliques, np.array([0, 3]), 4) == ()


def test_restrict_rejects_items_out_of_range():
    problem = problem_from_incidence(np.eye(3, dtype=bool), [1.0, 1.0, 1.0])
    with pytest.raises(ValueError, match=r"item indices must be in 0..2, got \[1, 5\]"):
        problem.restrict([1, 5])


def test_weights_given_are_not_frozen_in_place():
    weights = np.array([1.0, 2.0])
    problem_from_incidence(np.eye(2, dtype=bool), weights)
    weights[0] = 3.0  # the caller's array stays writable


def test_the_dominance_check_in_blocks_of_pairs_gives_the_same_sets(monkeypatch):
    import packing._presolve as presolve

    rng = np.random.default_rng(3)
    incidence = sp.csr_matrix(rng.random((40, 300)) < 0.08)
    whole = maximal_conflict_sets(incidence)
    monkeypatch.setattr(presolve, "_PAIRS_PER_BLOCK", 7)
    blocked = maximal_conflict_sets(incidence)
    assert whole[1] == blocked[1] and len(whole[0]) > 10
    assert [c.tolist() for c in whole[0]] == [c.tolist() for c in blocked[0]]


@settings(max_examples=60, deadline=None)
@given(wide_instances(), st.sampled_from([(), (1,), (1, 2), (2, 5, 9)]), st.sampled_from([1, 3, 1 << 18]))
def test_staged_and_blocked_dominance_checks_give_the_maximal_vertex_sets(incidence, stages, per_block):
    """A set found inside a larger one at some stage is not compared again; the sets left are the same
    whatever the stages and the block size."""
    import packing._presolve as presolve

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(presolve, "_STAGES", stages)
        patch.setattr(presolve, "_PAIRS_PER_BLOCK", per_block)
        cliques, _ = maximal_conflict_sets(sp.csr_matrix(incidence))
    assert [c.tolist() for c in cliques] == _naive_maximal_sets(incidence)
