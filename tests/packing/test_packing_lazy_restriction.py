"""Restricted problems derived lazily (Algorithm 1's shrinking problem): the same problems as a presolve from
the kept items' vertices, and the same greedy sequences as a straightforward greedy over the whole problem
that only masks the used items."""

from __future__ import annotations

import functools
import pickle
from dataclasses import replace

import numpy as np
import pytest

import packing
import rigs
import solvers
from packing._problem import Deferred, with_meta

#: The film layout (the Female face with many shapes) at a size a unit test affords.
FILM_LAYOUT = replace(rigs.PRESETS["film"], name="film-small", n_vertices=3000, n_shapes=400)


@functools.cache
def _analysis(preset: str | rigs.PresetSpec, **params) -> packing.Analysis:
    rig = rigs.generate(preset)
    return packing.analyse(rig, rigs.warp(rig, "alien").neutral, **params)


def _greedy_problems(analysis: packing.Analysis) -> list[tuple[packing.PackingProblem, tuple[int, ...]]]:
    """Each problem of the greedy sequence, derived from the previous one, with the items greedy chose."""
    greedy, steps, used = solvers.get("greedy"), [], []
    problem = analysis.problem_for()
    while problem.n_items:
        chosen = greedy.solve(problem).items
        steps.append((problem, chosen))
        used.extend(problem.shapes_of(chosen))
        problem = analysis.next_problem(problem, chosen, used)
    return steps


@pytest.mark.parametrize("preset", ["female", "digidouble", FILM_LAYOUT])
def test_restricted_problems_equal_a_presolve_of_their_items(preset):
    analysis = _analysis(preset)
    full = analysis.problem
    steps = _greedy_problems(analysis)
    assert len(steps) > 5
    for problem, _ in steps[1::3]:
        index = np.asarray(problem.meta["item_index"])
        fresh = packing.problem_from_incidence(full.incidence[index], problem.weights, items=problem.items)
        assert problem.n_cliques == len(fresh.cliques)
        assert [c.tolist() for c in problem.cliques] == [c.tolist() for c in fresh.cliques]
        assert problem.n_vertex_rows == fresh.n_vertex_rows
        assert (problem.incidence != fresh.incidence).nnz == 0
        assert problem.incidence.has_canonical_format
        assert np.array_equal(problem.item_active_counts, fresh.item_active_counts)
        assert np.array_equal(problem.item_shape_counts, fresh.item_shape_counts)


def test_a_restriction_reads_nothing_it_is_not_asked_for():
    full = _analysis("female").problem
    odd = full.restrict(range(1, full.n_items, 2))
    tagged = with_meta(odd, stage="test")
    again = tagged.restrict(range(20))  # items 1, 3, ..., 39 of the full problem
    for problem in (odd, tagged, again):
        assert isinstance(problem.__dict__["_incidence_value"], Deferred)
        assert isinstance(problem.__dict__["_cliques_value"], Deferred)
    assert tagged.meta["stage"] == "test" and again.n_items == 20
    fresh = packing.problem_from_incidence(full.incidence[1:40:2], again.weights, items=again.items)
    assert (again.incidence != fresh.incidence).nnz == 0
    assert [c.tolist() for c in again.cliques] == [c.tolist() for c in fresh.cliques]
    assert again.n_vertex_rows == fresh.n_vertex_rows and again.n_cliques == len(fresh.cliques) > 0


def test_a_restricted_problem_pickles_with_its_values():
    full = _analysis("female").problem
    restricted = full.restrict(range(0, full.n_items, 3)).restrict(range(0, 50, 2))
    copy = pickle.loads(pickle.dumps(restricted))
    assert (copy.incidence != restricted.incidence).nnz == 0
    assert [c.tolist() for c in copy.cliques] == [c.tolist() for c in restricted.cliques]
    assert copy.clique_arrays[1].tolist() == restricted.clique_arrays[1].tolist()


def numpy_greedy_sequence(analysis: packing.Analysis) -> list[tuple[str, ...]]:
    """Algorithm 2 repeated over the whole problem with a mask of the used items (Algorithm 1 without
    restricting anything): per expression, the remaining items by increasing key ``(lambda_max - lambda_k)
    |b_k|`` (sec. 4.5.2; ties by fewer active vertices, larger tie-break, index), each taken unless it
    shares a conflict set with a taken item or exceeds the cap."""
    full = analysis.problem
    starts, members, owner = full.clique_arrays
    holders = [owner[members == item] for item in range(full.n_items)]
    shapes = full.item_shape_counts
    active = full.item_active_counts
    used = np.zeros(full.n_items, dtype=bool)
    used_shapes: list[str] = []
    sequence = []
    while not used.all():
        left = np.flatnonzero(~used)
        weights = analysis.item_weights(used_shapes)[left] - full.tie_break[left]
        per_shape = weights / shapes[left]
        key = (max(1.0, per_shape.max()) - per_shape) * active[left]
        order = left[np.lexsort((left, -full.tie_break[left], active[left], key))]
        blocked, room, chosen = used.copy(), full.cap if full.cap is not None else np.inf, []
        for item in order.tolist():
            if blocked[item] or shapes[item] > room:
                continue
            chosen.append(item)
            room -= shapes[item]
            for r in holders[item].tolist():
                blocked[members[starts[r] : starts[r + 1]]] = True
        used[chosen] = True
        labels = tuple(full.shape_names[k] for item in sorted(chosen) for k in full.items[item])
        used_shapes.extend(labels)
        sequence.append(labels)
    return sequence


@pytest.mark.parametrize(
    ("preset", "params"),
    [
        ("female", {}),
        ("female", {"beta": 0.5}),
        ("digidouble", {"max_per_expression": 6}),
        ("male", {}),
        (FILM_LAYOUT, {}),
    ],
)
def test_greedy_sequence_equals_a_greedy_over_the_whole_problem(preset, params):
    analysis = _analysis(preset, **params)
    expressions = packing.sequence(analysis.rig, solvers.get("greedy"), analysis=analysis)
    reference = numpy_greedy_sequence(analysis)
    assert len(reference) > 3
    assert [sorted(expression.shapes) for expression in expressions] == [sorted(s) for s in reference]


def test_a_greedy_sequence_derives_no_conflict_sets_and_counts_them_when_read():
    analysis = _analysis(FILM_LAYOUT)
    expressions = packing.sequence(analysis.rig, solvers.get("greedy"), analysis=analysis)
    assert len(expressions) > 5
    assert all(isinstance(e.__dict__["_clique_rows_value"], Deferred) for e in expressions[1:])
    copies = pickle.loads(pickle.dumps(expressions[::-1]))[::-1]
    used: list[str] = []
    for expression, copy in zip(expressions, copies, strict=True):
        fresh = analysis.problem_for(used)
        assert expression.clique_rows == copy.clique_rows == len(fresh.cliques)
        assert expression == copy
        used.extend(expression.shapes)


def test_a_conflict_view_says_which_items_conflict_as_the_cliques_do():
    full = _analysis("female").problem
    restricted = full.restrict(range(0, full.n_items, 2)).restrict(range(3, 60))
    view = restricted.conflict_view
    assert view.sets is full.conflict_view.sets  # nothing derived
    assert np.array_equal(view.items, np.arange(0, full.n_items, 2)[3:60])
    local = np.full(view.sets.n_items, -1)
    local[view.items] = np.arange(view.items.size)
    pairs_in_view, pairs_in_cliques = set(), set()
    for members in view.sets.as_tuple():
        kept = local[members][local[members] >= 0].tolist()
        pairs_in_view.update((a, b) for a in kept for b in kept if a < b)
    for members in restricted.cliques:
        pairs_in_cliques.update((a, b) for a in members.tolist() for b in members.tolist() if a < b)
    assert pairs_in_view == pairs_in_cliques and pairs_in_view
    assert restricted.conflict_view.sets is not view.sets  # its own, once derived
