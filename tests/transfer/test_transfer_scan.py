"""Scan-like training expressions (`transfer.scan_expressions`): what each part of the model adds."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import rigs
import transfer
from transfer import ScanModel

NOTHING = ScanModel(corrective=0.0, noise=0.0, rotation=0.0, translation=0.0)


def only(**parts: float) -> ScanModel:
    """A model that adds only the given parts."""
    return ScanModel(**{"corrective": 0.0, "noise": 0.0, "rotation": 0.0, "translation": 0.0, **parts})


@pytest.fixture(scope="module")
def actor() -> rigs.Rig:
    """A tiny rig (it has static vertices) as the actor, made character-specific."""
    return rigs.warp(rigs.generate("tiny", seed=2), "big-eyes+character")


@pytest.fixture(scope="module")
def weights(actor: rigs.Rig) -> np.ndarray:
    rng = np.random.default_rng(4)
    return (rng.random((6, actor.n_shapes)) < 0.5).astype(float)


def test_a_model_that_adds_nothing_gives_the_linear_sums(actor, weights):
    linear = transfer.training_expressions(actor, weights)
    assert NOTHING.ideal and not ScanModel().ideal
    np.testing.assert_array_equal(transfer.scan_expressions(actor, weights, model=NOTHING), linear)


def test_scans_are_not_the_linear_sums_and_depend_on_the_session_seed(actor, weights):
    linear = transfer.training_expressions(actor, weights)
    first = transfer.scan_expressions(actor, weights, seed=0)
    again = transfer.scan_expressions(actor, weights, seed=0)
    other = transfer.scan_expressions(actor, weights, seed=1)
    np.testing.assert_array_equal(first, again)
    assert transfer.rms(first, linear) > 0 and transfer.rms(first, other) > 0
    assert first.shape == linear.shape


def test_the_first_scans_do_not_depend_on_how_many_follow(actor, weights):
    full = transfer.scan_expressions(actor, weights, seed=3)
    np.testing.assert_array_equal(transfer.scan_expressions(actor, weights[:2], seed=3), full[:2])


def test_noise_has_the_requested_size(actor, weights):
    linear = transfer.training_expressions(actor, weights)
    model = only(noise=1e-3)
    noisy = transfer.scan_expressions(actor, weights, seed=5, model=model)
    deviation = (noisy - linear).std()
    assert deviation == pytest.approx(1e-3 * actor.diagonal(), rel=0.1)


def test_a_corrective_needs_two_shapes_that_meet(actor):
    model = only(corrective=0.5)
    single = np.eye(actor.n_shapes)  # one shape per expression: nothing to correct
    np.testing.assert_allclose(
        transfer.scan_expressions(actor, single, model=model),
        transfer.training_expressions(actor, single),
        atol=1e-12 * actor.diagonal(),
    )
    lengths = np.linalg.norm(actor.deltas, axis=2)
    overlap = (lengths[:, None, :] > 0) & (lengths[None, :, :] > 0)
    k, m = np.argwhere(np.triu(overlap.any(axis=2), 1))[0]
    pair = np.zeros((1, actor.n_shapes))
    pair[0, [k, m]] = 1.0
    corrected = transfer.scan_expressions(actor, pair, model=model)[0]
    moved = np.linalg.norm(corrected - transfer.training_expressions(actor, pair)[0], axis=1)
    assert moved.max() > 0
    reach = (lengths[k] > 0) | (lengths[m] > 0)
    assert moved[~reach].max() < moved.max()  # widened only a little beyond the two supports


def test_correctives_scale_with_both_weights(actor):
    # Aligned on vertices no shape moves, which no corrective reaches without widening: no change.
    model = only(corrective=0.5, reach=0.0, stable_share=0.02)
    full = np.ones((1, actor.n_shapes))
    linear = transfer.training_expressions(actor, full)
    half = transfer.training_expressions(actor, 0.5 * full)
    scaled = transfer.scan_expressions(actor, 0.5 * full, model=model) - half
    whole = transfer.scan_expressions(actor, full, model=model) - linear
    np.testing.assert_allclose(scaled, 0.25 * whole, atol=1e-12)


def test_rigid_alignment_removes_the_head_motion(actor, weights):
    model = only(rotation=3.0, translation=0.02)
    aligned = transfer.scan_expressions(actor, weights, seed=2, model=model)
    linear = transfer.training_expressions(actor, weights)
    # The tiny rig has vertices no shape moves: Kabsch on them undoes the motion exactly.
    np.testing.assert_allclose(aligned, linear, atol=1e-9 * actor.diagonal())


def test_the_alignment_uses_the_vertices_the_expression_moves_least():
    rig = rigs.generate("female")  # every vertex moves in some shape
    weights = np.zeros((1, rig.n_shapes))
    weights[0, rig.index("jawOpen")] = 1.0
    model = only(rotation=2.0)
    aligned = transfer.scan_expressions(rig, weights, model=model)
    linear = transfer.training_expressions(rig, weights)
    moved = transfer.rms(
        transfer.scan_expressions(rig, weights, model=only(rotation=2.0, stable_share=1.0)), linear
    )
    assert transfer.rms(aligned, linear) < 0.1 * moved


def test_scipy_kabsch_matches_a_known_rotation(actor):
    turn = Rotation.from_euler("xyz", [2.0, -1.0, 1.5], degrees=True)
    reference = actor.neutral - actor.neutral.mean(axis=0)
    found, _ = Rotation.align_vectors(reference, turn.apply(reference))
    assert np.allclose((found * turn).as_matrix(), np.eye(3), atol=1e-12)


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"noise": -1.0}, r"ScanModel.noise must be >= 0"),
        ({"corrective": float("nan")}, r"ScanModel.corrective must be a finite number"),
        ({"noise_smoothing": 1.5}, r"ScanModel.noise_smoothing must be an integer"),
        ({"stable_share": 0.0}, r"ScanModel.stable_share must be in \(0, 1\]"),
        ({"rotation": True}, r"ScanModel.rotation must be a finite number"),
    ],
)
def test_bad_models_are_refused(fields, message):
    with pytest.raises(ValueError, match=message):
        ScanModel(**fields)


def test_bad_arguments_are_refused(actor, weights):
    with pytest.raises(ValueError, match="target must be a rigs.Rig"):
        transfer.scan_expressions(actor.neutral, weights)
    with pytest.raises(ValueError, match="seed must be a non-negative integer"):
        transfer.scan_expressions(actor, weights, seed=-1)
    with pytest.raises(ValueError, match=r"weights must have shape \(J, 12\)"):
        transfer.scan_expressions(actor, weights[:, :3])
    with pytest.raises(ValueError, match="model must be a transfer.ScanModel"):
        transfer.scan_expressions(actor, weights, model={"noise": 0})


def test_the_widened_shapes_are_prepared_once_per_target_content(actor, weights):
    from transfer import _scan

    rebuilt = rigs.warp(rigs.generate("tiny", seed=2), "big-eyes+character")  # equal content, new object
    assert _scan._scanner(rebuilt, ScanModel()) is _scan._scanner(actor, ScanModel())
    assert _scan._scanner(actor, only(noise=1e-3)) is not _scan._scanner(actor, ScanModel())
    scanner = _scan._scanner(actor, ScanModel())
    first = transfer.scan_expressions(actor, weights, seed=4)
    taken = len(scanner._scans)
    np.testing.assert_array_equal(transfer.scan_expressions(rebuilt, weights[:3], seed=4), first[:3])
    assert len(scanner._scans) == taken  # the session's first scans are taken once
