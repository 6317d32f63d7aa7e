"""Sanity properties of each transfer method."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.optimize import lsq_linear
from scipy.spatial.transform import Rotation

import transfer
from transfer.ebfr import fit_edge_frames
from transfer.ebfr_full import box_quadratic


def relative_error(estimate: np.ndarray, truth: np.ndarray) -> float:
    return transfer.rms(estimate, truth) / transfer.rms(np.zeros_like(truth), truth)


def rigid(template, rotation: np.ndarray, shift: np.ndarray):
    return replace(
        template, neutral=template.neutral @ rotation.T + shift, deltas=template.deltas @ rotation.T
    )


def test_delta_is_exact_for_a_translated_target(tiny_pair):
    template, _ = tiny_pair
    target = replace(template, neutral=template.neutral + [3.0, -1.0, 2.0])
    result = transfer.get("delta")(template, target.neutral)
    assert np.array_equal(result, target.deltas)
    result[0, 0] = 1.0  # a writable copy, not the rig's read-only array
    assert not np.array_equal(result, template.deltas)


def test_delta_is_not_exact_for_a_rotated_target(tiny_pair):
    template, _ = tiny_pair
    target = rigid(template, Rotation.from_euler("z", 30, degrees=True).as_matrix(), np.zeros(3))
    assert relative_error(transfer.get("delta")(template, target.neutral), target.deltas) > 0.1


@settings(max_examples=12, deadline=None)
@given(
    quaternion=st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4).filter(
        lambda q: np.linalg.norm(q) > 0.1
    ),
    shift=st.lists(st.floats(-50.0, 50.0), min_size=3, max_size=3),
)
def test_dt_is_exact_for_a_rigid_motion(tiny_pair, quaternion, shift):
    template, _ = tiny_pair
    target = rigid(template, Rotation.from_quat(quaternion).as_matrix(), np.array(shift))
    assert relative_error(transfer.get("dt")(template, target.neutral), target.deltas) <= 1e-9


def test_dt_without_alignment_bends_rotated_targets(tiny_pair):
    template, _ = tiny_pair
    target = rigid(template, Rotation.from_euler("xyz", [20, 30, 40], degrees=True).as_matrix(), np.zeros(3))
    assert relative_error(transfer.get("dt", align=False)(template, target.neutral), target.deltas) > 1e-3


def test_dt_is_exact_for_a_uniform_scale(tiny_pair):
    # Deformation gradients are invariant under a uniform scale of both meshes. Only exactly static
    # vertices are held: near-static ones would keep the unscaled template displacement.
    template, _ = tiny_pair
    target = replace(template, neutral=2.5 * template.neutral, deltas=2.5 * template.deltas)
    result = transfer.get("dt", static_tolerance=0.0)(template, target.neutral)
    assert relative_error(result, target.deltas) <= 1e-9


@pytest.mark.parametrize("name", ["ebfr", "plbs", "ebfr-full"])
def test_without_expressions_the_methods_reduce_to_dt(name, tiny_pair):
    template, target = tiny_pair
    dt = transfer.get("dt")(template, target.neutral)
    result = transfer.get(name)(
        template, target.neutral, np.zeros((0, template.n_shapes)), np.zeros((0, 600, 3))
    )
    gap = transfer.rms(result, dt) / transfer.rms(dt, target.deltas)
    error, baseline = transfer.rms(result, target.deltas), transfer.rms(dt, target.deltas)
    print(f"{name} with J=0: rms {error:.6g}, dt {baseline:.6g}")
    assert gap <= 0.02


@pytest.mark.parametrize(("name", "params"), [("ebfr", {"beta": 1e-9}), ("plbs", {"lambda_reg": 1e-12})])
def test_every_shape_alone_recovers_ground_truth(name, params, tiny_pair):
    template, target = tiny_pair
    weights = np.eye(template.n_shapes)
    examples = transfer.training_expressions(target, weights)
    result = transfer.get(name, **params)(template, target.neutral, weights, examples)
    error = relative_error(result, target.deltas)
    print(f"{name} {params}, every shape alone: relative error {error:.3g}")
    assert error <= 1e-6


def test_ebfr_error_grows_with_beta_towards_dt(tiny_pair, packing):
    template, target = tiny_pair
    weights = packing(template)
    examples = transfer.training_expressions(target, weights)
    dt = transfer.get("dt")(template, target.neutral)
    errors = [
        transfer.rms(
            transfer.get("ebfr", beta=beta)(template, target.neutral, weights, examples), target.deltas
        )
        for beta in (0.01, 0.1, 1.0, 10.0)
    ]
    far = transfer.get("ebfr", beta=1e8)(template, target.neutral, weights, examples)
    print("ebfr rms for beta 0.01, 0.1, 1, 10:", np.round(errors, 6), "dt:", transfer.rms(dt, target.deltas))
    assert errors == sorted(errors)
    assert transfer.rms(far, dt) <= 1e-4 * transfer.rms(dt, target.deltas)


def test_ebfr_leaves_uncovered_shapes_as_dt(tiny_pair):
    template, target = tiny_pair
    weights = np.zeros((2, template.n_shapes))
    weights[0, [0, 3]] = 1.0
    weights[1, 5] = 1.0
    examples = transfer.training_expressions(target, weights)
    result = transfer.get("ebfr")(template, target.neutral, weights, examples)
    dt = transfer.get("dt")(template, target.neutral)
    uncovered = ~weights.any(axis=0)
    np.testing.assert_allclose(result[uncovered], dt[uncovered], atol=1e-12 * template.diagonal())
    assert transfer.rms(result[~uncovered], target.deltas[~uncovered]) < transfer.rms(
        dt[~uncovered], target.deltas[~uncovered]
    )


def test_static_template_vertices_stay_fixed(tiny_pair, packing):
    template, target = tiny_pair
    weights = packing(template)
    examples = transfer.training_expressions(target, weights)
    result = transfer.get("ebfr")(template, target.neutral, weights, examples)
    static = np.linalg.norm(template.deltas, axis=-1) == 0
    assert static.any()
    assert np.array_equal(result[static], np.zeros((static.sum(), 3)))


@settings(max_examples=25, deadline=None)
@given(
    n_shapes=st.integers(1, 7),
    n_expressions=st.integers(1, 9),
    beta=st.floats(1e-3, 10.0),
    seed=st.integers(0, 2**16),
)
def test_batched_woodbury_solve_matches_dense_normal_equations(n_shapes, n_expressions, beta, seed):
    rng = np.random.default_rng(seed)
    n_triangles = 5
    prior = rng.normal(size=(n_triangles, 2, 3, n_shapes))
    regularisation = rng.uniform(1.0, 100.0, (n_triangles, n_shapes))
    weights = rng.integers(0, 2, (n_expressions, n_shapes)).astype(float)
    weights[0] = weights[-1]  # a repeated expression leaves W^T W singular
    observed = rng.normal(size=(n_triangles, 2, 3, n_expressions))
    result = fit_edge_frames(prior, regularisation, weights, observed, beta)
    for t in range(n_triangles):
        damping = beta * np.diag(regularisation[t])
        rhs = weights.T @ observed[t].reshape(6, -1).T + damping @ prior[t].reshape(6, -1).T
        expected = np.linalg.solve(weights.T @ weights + damping, rhs)
        np.testing.assert_allclose(result[t].reshape(6, -1).T, expected, rtol=1e-8, atol=1e-10)


def test_ebfr_full_with_one_iteration_is_ebfr(tiny_pair, packing):
    template, target = tiny_pair
    weights = packing(template)
    examples = transfer.training_expressions(target, weights)
    full, refitted = transfer.get("ebfr-full", iterations=1).fit(template, target.neutral, weights, examples)
    np.testing.assert_allclose(
        full, transfer.get("ebfr", beta=0.1)(template, target.neutral, weights, examples), atol=1e-12
    )
    assert np.array_equal(refitted, weights)


def test_ebfr_full_moves_perturbed_weights_towards_the_truth(tiny_pair, packing):
    template, target = tiny_pair
    weights = packing(template)
    examples = transfer.training_expressions(target, weights)
    rng = np.random.default_rng(1)
    perturbed = np.clip(weights + rng.uniform(-0.3, 0.3, weights.shape), 0.0, 1.0)
    method = transfer.get("ebfr-full", iterations=4)
    deltas, refitted = method.fit(template, target.neutral, perturbed, examples)
    before = np.abs(perturbed - weights).mean()
    after = np.abs(refitted - weights).mean()
    print(f"mean weight error {before:.3f} -> {after:.3f}")
    assert after < 0.9 * before
    assert ((refitted >= 0) & (refitted <= 1)).all()


def test_training_expressions_copy_the_weights(sheet):
    target = sheet(6, 7, 3)
    weights = np.array([[1.0, 0.0, 1.0], [0.0, 0.5, 0.0]])
    expressions = transfer.training_expressions(target, weights)
    np.testing.assert_allclose(expressions[0], target.neutral + target.deltas[0] + target.deltas[2])
    np.testing.assert_allclose(expressions[1], target.neutral + 0.5 * target.deltas[1])
    assert transfer.training_expressions(target, np.zeros((0, 3))).shape == (0, 42, 3)


@settings(max_examples=20, deadline=None)
@given(n_shapes=st.integers(1, 12), n_columns=st.integers(1, 4), seed=st.integers(0, 2**16))
def test_box_quadratic_matches_bounded_least_squares(n_shapes, n_columns, seed):
    rng = np.random.default_rng(seed)
    factor = rng.normal(size=(n_shapes + 3, n_shapes)) * rng.uniform(0.1, 10.0, n_shapes)
    targets = rng.normal(size=(n_shapes + 3, n_columns)) * 5.0
    hessian = factor.T @ factor + 1e-2 * np.eye(n_shapes)
    linear = factor.T @ targets
    result = box_quadratic(hessian, linear, np.full((n_shapes, n_columns), 0.5))
    stacked = np.r_[factor, 0.1 * np.eye(n_shapes)]
    for column in range(n_columns):
        rhs = np.r_[targets[:, column], np.zeros(n_shapes)]
        expected = lsq_linear(stacked, rhs, bounds=(0.0, 1.0), method="bvls").x
        np.testing.assert_allclose(result[:, column], expected, atol=1e-6)
