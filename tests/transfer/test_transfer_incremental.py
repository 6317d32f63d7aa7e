"""The fast paths of deformation transfer and example-based rigging give the plain solve, to 1e-10.

The fast paths evaluate the prior and the regularisation only on the triangles around each shape's free
vertices, solve each constraint set on its own factorised block, share one set-up between ``dt`` and
``ebfr``, fit each expression of a packing once and update the estimate of J + 1 expressions from that of
J (`transfer.Transfer.prefixes`). The reference (`conftest._reference_step_a`) does none of that: dense
per-triangle normal equations and a dense vertex solve for every shape.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import rigs
import transfer
from transfer import _regularisation, _setup, ebfr
from transfer._inputs import check_inputs
from transfer.deformation import deformation_transfer

RELATIVE = 1e-10


def assert_close(found: np.ndarray, expected: np.ndarray) -> None:
    """Equal to within ``RELATIVE`` of the largest displacement."""
    assert found.shape == expected.shape
    scale = np.abs(expected).max()
    assert np.abs(found - expected).max() <= RELATIVE * scale


def warped(rig: rigs.Rig, seed: int) -> rigs.Rig:
    """A smooth random nonlinear warp of the rig: scale, shear, bend and a rotation."""
    rng = np.random.default_rng(seed)
    centre = rig.neutral.mean(axis=0)
    linear = np.diag(rng.uniform(0.8, 1.3, 3)) + rng.uniform(-0.15, 0.15, (3, 3))
    angle = rng.uniform(-0.4, 0.4)
    turn = np.array([[np.cos(angle), -np.sin(angle), 0.0], [np.sin(angle), np.cos(angle), 0.0], [0, 0, 1]])
    bend = rng.uniform(-0.1, 0.1, 3)

    def move(points: np.ndarray) -> np.ndarray:
        local = (points - centre) @ linear.T
        return (local + bend * np.sin(3.0 * local[..., [1, 2, 0]])) @ turn.T + centre

    neutral = move(rig.neutral)
    return replace(rig, neutral=neutral, deltas=move(rig.neutral + rig.deltas) - neutral)


def random_packing(rng: np.random.Generator, n_shapes: int, n_expressions: int) -> np.ndarray:
    """0/1 weights: each shape in at most one of ``n_expressions`` expressions, some in none."""
    slot = rng.integers(-1, n_expressions, n_shapes)
    weights = np.zeros((n_expressions, n_shapes))
    weights[slot[slot >= 0], np.flatnonzero(slot >= 0)] = 1.0
    return weights


def noisy_examples(target: rigs.Rig, weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """The linear sums plus small noise, so every triangle's residual is nonzero."""
    examples = transfer.training_expressions(target, weights)
    return examples + rng.normal(scale=1e-3, size=examples.shape)


#: Drawn sizes of a small case: sheet columns and rows, shapes, expressions, and a seed.
SIZES = {
    "n_columns": st.integers(5, 9),
    "n_rows": st.integers(5, 9),
    "n_shapes": st.integers(2, 6),
    "n_expressions": st.integers(1, 4),
    "seed": st.integers(0, 2**16),
}


def make_case(sheet, n_columns, n_rows, n_shapes, n_expressions, seed):
    """A small sheet rig with local bumps, a warped target, a random packing and noisy examples."""
    template = sheet(n_columns, n_rows, n_shapes, seed)
    rng = np.random.default_rng(seed)
    weights = random_packing(rng, n_shapes, n_expressions)
    target = warped(template, seed + 1)
    return template, target, weights, noisy_examples(target, weights, rng)


@settings(max_examples=20, deadline=None)
@given(**SIZES, beta=st.floats(0.01, 10.0))
def test_ebfr_at_every_j_is_the_plain_solve(sheet, reference_step_a, beta, **sizes):
    template, target, weights, examples = make_case(sheet, **sizes)
    method = transfer.get("ebfr", beta=beta)
    first = method.prefixes(template, target.neutral, weights, examples)
    for j in range(weights.shape[0] + 1):
        expected = reference_step_a(template, target.neutral, weights[:j], examples[:j], beta=beta)
        assert_close(first(j), expected)
        assert_close(method(template, target.neutral, weights[:j], examples[:j]), expected)


@settings(max_examples=15, deadline=None)
@given(**SIZES, kappa=st.floats(0.01, 1.0), theta=st.floats(0.0, 3.0), absolute=st.booleans())
def test_ebfr_regularisation_parameters_match_the_plain_solve(
    sheet, reference_step_a, kappa, theta, absolute, **sizes
):
    template, target, weights, examples = make_case(sheet, **sizes)
    scale = "absolute" if absolute else "peak"
    found = transfer.get("ebfr", beta=0.1, kappa=kappa, theta=theta, motion_scale=scale)(
        template, target.neutral, weights, examples
    )
    expected = reference_step_a(
        template, target.neutral, weights, examples, kappa=kappa, theta=theta, motion_scale=scale
    )
    assert_close(found, expected)


@settings(max_examples=15, deadline=None)
@given(**SIZES)
def test_shared_shapes_take_the_joint_path_at_every_j(sheet, reference_step_a, **sizes):
    template, target, weights, examples = make_case(sheet, **sizes)
    rng = np.random.default_rng(sizes["seed"])
    shared = np.r_[weights, (rng.random((2, template.n_shapes)) < 0.5).astype(float)]
    shared_examples = np.r_[examples, noisy_examples(target, shared[-2:], rng)]
    first = transfer.get("ebfr", beta=0.1).prefixes(template, target.neutral, shared, shared_examples)
    for j in range(shared.shape[0], -1, -1):  # falling J: the estimate is rebuilt, not updated
        expected = reference_step_a(template, target.neutral, shared[:j], shared_examples[:j])
        assert_close(first(j), expected)


@settings(max_examples=15, deadline=None)
@given(**SIZES)
def test_dt_is_the_plain_solve_without_examples(sheet, reference_step_a, **sizes):
    template, target, _, _ = make_case(sheet, **sizes)
    none = np.zeros((0, template.n_shapes))
    expected = reference_step_a(template, target.neutral, none, np.zeros((0, template.n_vertices, 3)))
    assert_close(transfer.get("dt")(template, target.neutral), expected)
    plain = deformation_transfer(template.neutral, template.deltas, target.neutral, template.triangles)
    assert_close(plain, expected)


def test_prefixes_equal_calls_for_every_method_and_order(tiny_pair, packing):
    template, target = tiny_pair
    weights = packing(template, 5)
    examples = transfer.scan_expressions(target, weights, seed=2)
    for name in ("ebfr", "dt", "delta", "plbs"):
        method = transfer.get(name)
        first = method.prefixes(template, target.neutral, weights, examples)
        for j in (2, 5, 1, 1, 0, 3):
            expected = method(template, target.neutral, weights[:j], examples[:j])
            found = first(j)
            np.testing.assert_allclose(found, expected, rtol=0, atol=RELATIVE * np.abs(expected).max())
            found[...] = 0.0  # each call returns a new array
        with pytest.raises(ValueError, match=r"integer in \[0, 5\], got 6"):
            first(6)


def test_prefixes_check_the_inputs_once(tiny_pair):
    template, target = tiny_pair
    with pytest.raises(ValueError, match="examples holds 1 expressions but weights has 2 rows"):
        transfer.get("ebfr").prefixes(
            template, target.neutral, np.zeros((2, template.n_shapes)), np.zeros((1, template.n_vertices, 3))
        )


@pytest.fixture
def case():
    template = rigs.generate("tiny", seed=1)
    target = rigs.warp(template, "alien+character")
    weights = np.zeros((3, template.n_shapes))
    for j, shapes in enumerate(([0, 3, 6], [1, 4], [7, 9, 10])):
        weights[j, shapes] = 1.0
    return template, target, weights, transfer.scan_expressions(target, weights, seed=1)


def test_dt_and_ebfr_share_one_setup_kept_by_content(case):
    template, target, weights, examples = case
    setup = _setup.transfer_setup(template, target.neutral, static_tolerance=1e-6, align=True)
    fresh = rigs.generate("tiny", seed=1)  # another object with the same content
    again = _setup.transfer_setup(
        fresh, rigs.warp(fresh, "alien+character").neutral, static_tolerance=1e-6, align=True
    )
    assert again is setup
    assert _setup.transfer_setup(template, target.neutral, static_tolerance=0.0, align=True) is not setup
    dt = transfer.get("dt")(template, target.neutral)
    np.testing.assert_array_equal(dt, setup.transferred)
    np.testing.assert_array_equal(
        transfer.get("ebfr")(template, target.neutral, weights[:0], examples[:0]), dt
    )
    dt[...] = 0.0  # a copy: the shared estimate is read-only and unchanged
    assert not setup.transferred.flags.writeable and np.abs(setup.transferred).max() > 0


@pytest.fixture
def fits(monkeypatch) -> list[int]:
    """Every step-A fit of one expression alone (`ebfr.ExpressionFit.fitted`) from now on, as its number
    of shapes."""
    real = ebfr.ExpressionFit.fitted
    found: list[int] = []

    def counted(self, setup, beta):
        found.append(self.system.shapes.size)
        return real(self, setup, beta)

    monkeypatch.setattr(ebfr.ExpressionFit, "fitted", counted)
    return found


def test_each_expression_is_fitted_once_across_j_values(case, fits):
    template, target, weights, examples = case
    rigging = ebfr.GradientSpaceRigging(
        check_inputs(template, target.neutral, weights, examples, method="ebfr")
    )
    rigging.state.expressions.clear()  # earlier tests may have fitted these expressions already
    once = sorted(int(np.count_nonzero(row)) for row in weights)  # one fit of each expression alone
    first = transfer.get("ebfr").prefixes(template, target.neutral, weights, examples)
    for j in range(weights.shape[0] + 1):
        first(j)
    assert sorted(fits) == once
    for j in (3, 1, 2):  # falling J starts again from deformation transfer, with the fits kept
        first(j)
    transfer.get("ebfr")(template, target.neutral, weights[:2], examples[:2])
    transfer.get("ebfr").prefixes(template, target.neutral, weights, examples)(3)
    assert sorted(fits) == once
    assert len(rigging.state.expressions) == weights.shape[0]


def test_a_new_beta_or_example_refits_each_expression_from_what_it_kept(sheet, reference_step_a, monkeypatch):
    """GCV picks another beta for every J, and every capture session brings other examples of the same
    expressions: the prior of each expression is evaluated once for all of them."""
    template, target, weights, examples = make_case(sheet, 8, 9, 6, 4, seed=7)
    rigging = ebfr.GradientSpaceRigging(
        check_inputs(template, target.neutral, weights, examples, method="ebfr")
    )
    for memo in (rigging.state.systems, rigging.state.fits, rigging.state.expressions):
        memo.clear()  # earlier tests may have prepared these expressions already
    assert rigging.setup.transferred is not None  # deformation transfer evaluates every prior once
    evaluated: list[int] = []
    block = rigging.setup.prior.block

    def counted(faces: np.ndarray, shapes: np.ndarray) -> np.ndarray:
        evaluated.append(shapes.size)
        return block(faces, shapes)

    monkeypatch.setattr(rigging.setup.prior, "block", counted)
    other = noisy_examples(target, weights, np.random.default_rng(8))
    for session in (examples, other):
        first = (
            transfer.get("ebfr", beta=0.1)
            .rigging(check_inputs(template, target.neutral, weights, session, method="ebfr"))
            .prefixes(weights, lambda count: 0.5**count)
        )
        for j in (1, 2, 4, 3, 4, 1, 0):
            expected = reference_step_a(template, target.neutral, weights[:j], session[:j], beta=0.5**j)
            assert_close(first(j), expected)
    assert sorted(evaluated) == sorted(int(np.count_nonzero(row)) for row in weights if row.any())


def test_motion_peaks_measure_every_triangle_where_the_moving_ones_do_not_decide(sheet):
    """A rigid translation of a separate part barely bends any triangle: its peak is found elsewhere."""
    rig = sheet(6, 7, 3, 5)
    n_vertices = rig.n_vertices
    neutral = np.r_[rig.neutral, rig.neutral + [3.0, 0.0, 0.0]]
    triangles = np.r_[rig.triangles, rig.triangles + n_vertices]
    deltas = np.zeros((4, 2 * n_vertices, 3))
    deltas[:3, :n_vertices] = rig.deltas
    deltas[3, n_vertices:] = [0.0, 0.5, 0.0]  # the second sheet moves rigidly
    deltas[3, :n_vertices] = 1e-8 * np.random.default_rng(0).normal(size=(n_vertices, 3))  # nearly static
    two = rigs.Rig(neutral, deltas, triangles, ("a", "b", "c", "shift"))
    setup = _setup.TransferSetup(
        two.neutral,
        two.deltas,
        two.triangles,
        two.neutral,
        static_tolerance=1e-6,
        align=True,
        factor_budget=0,
    )
    everywhere = np.arange(triangles.shape[0])
    brute = np.array(
        [np.sqrt(np.sum(setup.prior.moved(everywhere, k) ** 2, axis=(1, 2))).max() for k in range(4)]
    )
    np.testing.assert_allclose(_regularisation.motion_peaks(setup), brute, rtol=1e-14)
    assert brute[3] < 1e-7  # found on the nearly static sheet, not on the translated one
