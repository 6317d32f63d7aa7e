"""The clique model restricted to some of its items (`solvers._model.CliqueModel.restricted`): the rows cut
to the kept items, those inside another dropped, so that the restricted model has the packings and the
linear relaxation of the rows as cut (Carrigan et al. 2020, eq. 3 after presolve)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.optimize import linprog

from packing import pack_bit_rows
from solvers._model import CliqueModel, widest_rows
from solvers.testing import random_problem


def _cut_rows(model: CliqueModel, keep: np.ndarray) -> list[frozenset[int]]:
    """Every row of ``model`` cut to ``keep`` (renumbered as ``keep`` orders them), duplicates included."""
    position = {int(item): r for r, item in enumerate(keep)}
    cut = (model.row(r).tolist() for r in range(model.n_rows))
    rows = [frozenset(position[i] for i in row if i in position) for row in cut]
    return [row for row in rows if len(row) >= 2]


def _lp_bound(model: CliqueModel) -> float:
    answer = linprog(-model.weights, A_ub=model.matrix(), b_ub=model.upper(), bounds=(0, 1), method="highs")
    assert answer.status == 0
    return -answer.fun


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 100_000), cap=st.sampled_from([None, 3]), share=st.floats(0.2, 1.0))
def test_restricted_rows_are_the_widest_cut_rows(seed, cap, share):
    model = CliqueModel.from_problem(random_problem(14, 40, seed=seed, active=(2, 7), cap=cap))
    rng = np.random.default_rng(seed)
    keep = np.flatnonzero(rng.random(model.n_items) < share)
    restricted = model.restricted(keep)
    cut = _cut_rows(model, keep)
    rows = [frozenset(restricted.row(r).tolist()) for r in range(restricted.n_rows)]
    assert all(np.all(np.diff(restricted.row(r)) > 0) for r in range(restricted.n_rows))  # ascending
    assert len(set(rows)) == len(rows)  # no duplicate
    assert not any(a < b for a in rows for b in rows)  # none inside another
    assert set(rows) == {row for row in cut if not any(row < other for other in cut)}  # the widest cut rows
    np.testing.assert_array_equal(restricted.weights, model.weights[keep])
    np.testing.assert_array_equal(restricted.shape_counts, model.shape_counts[keep])
    counts = model.shape_counts[keep]
    assert restricted.cap == (model.cap if model.cap is not None and model.cap < counts.sum() else None)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 100_000), cap=st.sampled_from([None, 3]))
def test_restricted_model_keeps_the_cut_rows_linear_relaxation(seed, cap):
    """Rows inside others are implied in the relaxation too: the LP bound is the one of every cut row."""
    model = CliqueModel.from_problem(random_problem(14, 40, seed=seed, active=(2, 7), cap=cap))
    keep = np.flatnonzero(np.random.default_rng(seed).random(model.n_items) < 0.6)
    restricted = model.restricted(keep)
    cut = _cut_rows(model, keep)
    items = [sorted(row) for row in cut]
    starts = np.concatenate([[0], np.cumsum([len(row) for row in items])]).astype(np.int64)
    flat = np.asarray([i for row in items for i in row], dtype=np.int64)
    every_cut_row = CliqueModel(restricted.weights, starts, flat, restricted.shape_counts, restricted.cap)
    assert _lp_bound(restricted) == pytest.approx(_lp_bound(every_cut_row), rel=1e-9, abs=1e-12)


@pytest.mark.parametrize(
    ("rows", "expected"),
    [
        ([[1, 1, 0, 0], [1, 1, 0, 0], [1, 1, 1, 0]], [2]),  # duplicates and a subset: the superset only
        ([[1, 1, 0, 0], [0, 1, 1, 0], [1, 0, 1, 0]], [0, 1, 2]),  # pairwise overlapping, none inside another
        ([[0, 0, 1, 1], [0, 0, 1, 1]], [0]),  # equal rows: the first
        ([[1, 0, 0, 0], [0, 0, 0, 0], [0, 1, 1, 0]], [2]),  # rows of fewer than two items constrain nothing
        ([[0, 0, 0, 0]], []),
    ],
)
def test_widest_rows(rows, expected):
    words = pack_bit_rows(np.asarray(rows, dtype=bool))
    np.testing.assert_array_equal(widest_rows(words), expected)


def test_widest_rows_across_words():
    """Rows of more than 64 items compare word by word: a row inside another only in its second word is not
    inside it."""
    rows = np.zeros((3, 130), dtype=bool)
    rows[0, [0, 1, 100]] = True
    rows[1, [0, 1, 101]] = True
    rows[2, [0, 1, 100, 129]] = True
    np.testing.assert_array_equal(widest_rows(pack_bit_rows(rows)), [1, 2])


@settings(max_examples=60, deadline=None)
@given(
    rows=st.lists(st.lists(st.booleans(), min_size=70, max_size=70), max_size=12),
    block=st.sampled_from([1, 2, 5, 1024]),
)
def test_widest_rows_against_every_pair_compared_in_blocks(rows, block):
    """Block by block (`WIDEST_BLOCK`), the rows kept are those that a comparison of every pair keeps."""
    import solvers._model as model_module

    members = [frozenset(np.flatnonzero(row).tolist()) for row in rows]
    expected = [
        r
        for r, row in enumerate(members)
        if len(row) >= 2
        and not any(row < other for other in members)
        and not any(row == other for other in members[:r])
    ]
    words = pack_bit_rows(np.asarray(rows, dtype=bool).reshape(len(rows), 70))
    saved = model_module.WIDEST_BLOCK
    model_module.WIDEST_BLOCK = block
    try:
        np.testing.assert_array_equal(widest_rows(words), expected)
    finally:
        model_module.WIDEST_BLOCK = saved


def test_restricted_to_no_item_or_one_keeps_the_index_type():
    model = CliqueModel.from_problem(random_problem(10, 30, seed=3, active=(2, 6), cap=None))
    for keep in (np.zeros(0, dtype=np.int64), np.array([0])):
        restricted = model.restricted(keep)
        assert restricted.n_items == keep.size and restricted.n_rows == 0
        assert restricted.row_items.dtype == model.row_items.dtype and restricted.row_starts.tolist() == [0]
    narrowed = model.restricted(np.arange(model.n_items))
    assert narrowed.row_items.dtype == model.row_items.dtype
