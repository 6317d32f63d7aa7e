"""Equivalence of the fast paths of the presolve and of the analysis with their plain definitions: restricted
conflict sets against a presolve from the vertices (both ways of finding dominated sets), the flat forms of
the conflict sets, and the active-only displacement lengths against the dense ones."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import packing._presolve as presolve
import rigs
from packing import problem_from_incidence
from packing._binary import (
    active_lengths,
    displacement_norms,
    empty_mask,
    largest_lengths,
    lengths_matrix,
    masks_from_norms,
    sparse_masks,
)
from packing._importance import displacement_strength
from solvers.testing import face_like_problem, random_problem


def problems(seed: int, kind: str):
    if kind == "random":
        return random_problem(30, 60, seed=seed, active=(2, 14))
    return face_like_problem(60, 900, seed=seed)


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    kind=st.sampled_from(["random", "face"]),
    share=st.floats(0.0, 1.0),
    dense=st.sampled_from([0, 1 << 40]),
)
def test_restricted_conflict_sets_are_the_presolve_of_the_restricted_incidence(seed, kind, share, dense):
    problem = problems(seed, kind)
    keep = np.flatnonzero(np.random.default_rng(seed).random(problem.n_items) < share)
    with pytest.MonkeyPatch.context() as patch:  # every candidate against every set, or by rarest item
        patch.setattr(presolve, "_DENSE_COMPARISONS", dense)
        restricted = problem.restrict(keep)
        starts, members = problem.restricted_conflict_sets(keep)
    fresh, rows = presolve.maximal_conflict_sets(problem.incidence[keep])
    assert [c.tolist() for c in restricted.cliques] == [c.tolist() for c in fresh]
    assert restricted.n_vertex_rows == rows
    flat = [members[a:b].tolist() for a, b in zip(starts[:-1], starts[1:], strict=True)]
    assert flat == [c.tolist() for c in fresh]


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10_000), steps=st.integers(1, 6))
def test_chains_of_restrictions_match_one_restriction(seed, steps):
    problem = face_like_problem(80, 900, seed=seed)
    rng = np.random.default_rng(seed)
    current, index = problem, np.arange(problem.n_items)
    for _ in range(steps):
        keep = np.flatnonzero(rng.random(current.n_items) < 0.8)
        current, index = current.restrict(keep), index[keep]
    once = problem.restrict(index)
    assert [c.tolist() for c in current.cliques] == [c.tolist() for c in once.cliques]
    starts, members, owner = current.clique_arrays
    assert np.array_equal(np.repeat(np.arange(starts.size - 1), np.diff(starts)), owner)
    assert [members[a:b].tolist() for a, b in zip(starts[:-1], starts[1:], strict=True)] == [
        c.tolist() for c in current.cliques
    ]


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10_000), steps=st.integers(1, 4))
def test_conflict_bits_follow_restrictions(seed, steps):
    """Bits derived along a chain of restrictions are those of the conflict graph of each problem."""
    problem = face_like_problem(70, 900, seed=seed)
    rng = np.random.default_rng(seed)
    current = problem
    current.conflict_bits  # noqa: B018 - computed, so that restrictions derive theirs
    for _ in range(steps):
        current = current.restrict(np.flatnonzero(rng.random(current.n_items) < 0.7))
        assert "conflict_bits" in current.__dict__
    incidence = current.incidence.astype(np.int64)
    graph = (incidence @ incidence.T).toarray() > 0
    for a, b in current.apart:
        graph[a, b] = graph[b, a] = True
    np.fill_diagonal(graph, True)
    n_items = current.n_items
    bits = np.unpackbits(current.conflict_bits.astype(">u8").view(np.uint8), axis=1, count=n_items)
    assert np.array_equal(bits.astype(bool), graph)


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10_000), kind=st.sampled_from(["random", "face"]), share=st.floats(0.3, 1.0))
def test_neighbour_lists_are_the_conflict_graph(seed, kind, share):
    """`ConflictSets.neighbours` (what Algorithm 2 blocks after each choice) lists, for each item, itself and
    the items it shares a vertex with or is apart from, ascending, once each."""
    problem = problems(seed, kind)
    rng = np.random.default_rng(seed)
    problem = problem.restrict(np.flatnonzero(rng.random(problem.n_items) < share))
    incidence = problem.incidence.astype(np.int64)
    graph = (incidence @ incidence.T).toarray() > 0
    for a, b in problem.apart:
        graph[a, b] = graph[b, a] = True
    np.fill_diagonal(graph, True)
    starts, items = problem._conflict_sets.neighbours
    assert starts.size == problem.n_items + 1
    assert [items[a:b].tolist() for a, b in zip(starts[:-1], starts[1:], strict=True)] == [
        np.flatnonzero(row).tolist() for row in graph
    ]


def test_clique_arrays_of_a_problem_built_from_the_incidence():
    problem = problem_from_incidence(
        np.array([[1, 1, 0, 0], [0, 1, 1, 0], [0, 0, 1, 1], [1, 0, 0, 1]]), np.ones(4)
    )
    starts, members, owner = problem.clique_arrays
    assert [members[a:b].tolist() for a, b in zip(starts[:-1], starts[1:], strict=True)] == [
        c.tolist() for c in problem.cliques
    ]
    assert owner.tolist() == [0, 0, 1, 1, 2, 2, 3, 3]
    assert not members.flags.writeable


@pytest.mark.parametrize("preset", ["tiny", "female"])
def test_active_only_lengths_give_the_dense_figures_bit_for_bit(preset):
    rig = rigs.generate(preset)
    norms = displacement_norms(rig.deltas)
    masks = masks_from_norms(norms, 0.3, empty_mask(norms, 1e-6, rig.diagonal()))
    active = sparse_masks(masks)
    lengths = lengths_matrix(norms, active)
    rows, cols = np.nonzero(masks)
    assert np.array_equal(active_lengths(lengths, active), norms[rows, cols])
    assert np.array_equal(active_lengths(norms, active), norms[rows, cols])
    assert np.array_equal(displacement_strength(lengths, masks), displacement_strength(norms, masks))
    nonempty = masks.any(axis=1)
    assert np.array_equal(largest_lengths(lengths)[nonempty], largest_lengths(norms)[nonempty])
    # A sparse matrix with more entries than the masks still gives the lengths of the active ones.
    everything = lengths_matrix(norms, sparse_masks(norms > 0))
    assert np.array_equal(active_lengths(everything, active), norms[rows, cols])


def test_displacement_norms_are_the_euclidean_lengths():
    deltas = np.random.default_rng(3).normal(size=(4, 7, 3))
    assert np.array_equal(displacement_norms(deltas), np.sqrt(np.einsum("knd,knd->kn", deltas, deltas)))
    assert np.allclose(displacement_norms(deltas), np.linalg.norm(deltas, axis=2))
