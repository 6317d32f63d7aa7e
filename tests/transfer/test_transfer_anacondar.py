"""AnaConDaR (Wagner et al. 2024): conformance, exactness where it must be exact, its settings."""

from __future__ import annotations

import numpy as np
import pytest

import rigs
import transfer
from transfer._adt import Settings, anatomy
from transfer._embedding import embed_examples
from transfer._features import find_features
from transfer._head import HeadTemplate, skin_vertices
from transfer.anacondar import AnaConDaR
from transfer.testing import parametrize_with_checks


@parametrize_with_checks([AnaConDaR(), AnaConDaR(adt="dt", characteristics=False)])
def test_anacondar_conforms(method, check):
    check(method)


def relative(estimate: np.ndarray, truth: np.ndarray) -> float:
    return transfer.rms(estimate, truth) / transfer.rms(np.zeros_like(truth), truth)


def test_every_shape_its_own_example_reproduces_the_target(tiny_pair):
    # The examples take precedence: anacon's characteristics and anatomy constrain only what they leave.
    template, target = tiny_pair
    weights = np.eye(template.n_shapes)
    examples = transfer.training_expressions(target, weights)
    ebfr = relative(transfer.get("ebfr")(template, target.neutral, weights, examples), target.deltas)
    plain = relative(
        AnaConDaR(characteristics=False)(template, target.neutral, weights, examples), target.deltas
    )
    full = relative(AnaConDaR()(template, target.neutral, weights, examples), target.deltas)
    print(f"relative RMS: anacondar {full:.3g}, without characteristics {plain:.3g}, ebfr {ebfr:.3g}")
    assert full <= 1e-3 and plain <= 1e-3


def test_frames_are_retargeted_whole(tiny_pair):
    template, target = tiny_pair
    method = AnaConDaR()
    weights = np.eye(template.n_shapes)[:3]
    examples = transfer.training_expressions(target, weights)
    single = np.eye(template.n_shapes)[[4, 7]]
    np.testing.assert_allclose(
        method.retarget(template, target.neutral, weights, examples, single),
        method(template, target.neutral, weights, examples)[[4, 7]],
        atol=1e-9 * np.abs(target.deltas).max(),
    )
    # On the template itself a frame that mixes shapes comes back as it is.
    frames = np.zeros((2, template.n_shapes))
    frames[0, [0, 5, 9]] = [0.3, 0.8, 0.5]
    frames[1, [2, 3]] = 1.0
    own = method.retarget(template, template.neutral, frames=frames)
    truth = np.tensordot(frames, template.deltas, axes=1)
    assert np.abs(own - truth).max() <= 1e-6 * np.abs(truth).max()
    with pytest.raises(ValueError, match="frames"):
        method.retarget(template, target.neutral, frames=np.ones((2, 3)))


def test_adt_of_a_uniformly_scaled_character_is_the_scaled_shape():
    template = rigs.generate("tiny")
    head = anatomy(template, 1.6 * template.neutral, Settings())
    found = head.adt(head.source_deltas)
    assert np.abs(found - 1.6 * template.deltas).max() <= 1e-6 * 1.6 * np.abs(template.deltas).max()


def test_adt_and_anacon_are_the_identity_on_the_template_itself():
    template = rigs.generate("arkit52")
    head = anatomy(template, template.neutral, Settings(iterations=4))
    size = np.abs(template.deltas).max()
    assert np.abs(head.adt(head.source_deltas[:8]) - template.deltas[:8]).max() <= 1e-6 * size
    assert np.abs(head.anacon(template.deltas) - template.deltas).max() <= 1e-6 * size


def test_embedding_recovers_the_expressions_of_the_template_itself():
    # Eqs. 20-21: examples of the template on its own neutral embed to their own weights.
    template = rigs.generate("tiny")
    weights = np.zeros((3, template.n_shapes))
    weights[0, [0, 3]] = weights[1, [1, 5]] = weights[2, [2, 7, 9]] = 1.0
    offsets = np.einsum("jk,knd->jnd", weights, template.deltas)
    head = anatomy(template, template.neutral, Settings())
    found = embed_examples(head, offsets, lambda_reg=1e-6, scale=template.diagonal() / 300)
    np.testing.assert_allclose(found, weights, atol=1e-3)


def test_embedding_on_another_character_is_close_to_the_true_weights(tiny_pair):
    template, target = tiny_pair
    weights = np.zeros((2, template.n_shapes))
    weights[0, [0, 3]] = weights[1, [4, 6]] = 1.0
    offsets = transfer.training_expressions(target, weights) - target.neutral
    found = embed_examples(
        anatomy(template, target.neutral, Settings()), offsets, 0.01, template.diagonal() / 300
    )
    embedded = np.einsum("jk,knd->jnd", found, template.deltas)
    truth = np.einsum("jk,knd->jnd", weights, template.deltas)
    assert relative(embedded, truth) <= 0.1


@pytest.mark.parametrize("preset", ["tiny", "arkit52"])
def test_the_head_embeds_the_skin_exactly_and_finds_the_face(preset):
    rig = rigs.generate(preset)
    skin = skin_vertices(rig.n_vertices, rig.triangles)
    camera = rigs.frontal_camera(rig)
    features = find_features(rig.neutral, rig.triangles, skin, camera, rig.regions)
    head = HeadTemplate.build(rig.neutral, rig.deltas, rig.triangles, rig.names, camera, features, 400)
    fitted = head.fit(rig.neutral)
    assert (head.embed_tet[skin] >= 0).all()
    np.testing.assert_allclose(fitted.embedding @ fitted.rest, rig.neutral, atol=1e-9 * fitted.size)
    assert len(features.eye_openings) and len(features.eye_sockets) and len(features.lip_contour)
    assert head.jaw.any() and head.jaw_track.size and head.cranium_track.size


def test_the_patch_blend_alone_is_alm_and_needs_no_head(tiny_pair, monkeypatch):
    template, target = tiny_pair
    alm = AnaConDaR(missing=False, anacon=False)
    monkeypatch.setattr(AnaConDaR, "anatomy", lambda *_: pytest.fail("ALM built a head"))
    assert not alm(template, target.neutral).any()  # nothing explained without examples
    weights = np.eye(template.n_shapes)
    examples = transfer.training_expressions(target, weights)
    assert relative(alm(template, target.neutral, weights, examples), target.deltas) <= 1e-3


def test_settings_are_checked():
    with pytest.raises(ValueError, match="adt"):
        AnaConDaR(adt="ebfr")
    with pytest.raises(ValueError, match="characteristics"):
        AnaConDaR(characteristics="maybe")


def test_the_ablations_differ_from_the_method(tiny_pair):
    template, target = tiny_pair
    weights = np.zeros((2, template.n_shapes))
    weights[0, :4] = weights[1, 6:9] = 1.0
    examples = transfer.training_expressions(target, weights)
    results = {
        label: method(template, target.neutral, weights, examples)
        for label, method in {
            "full": AnaConDaR(),
            "dt": AnaConDaR(adt="dt"),
            "no characteristics": AnaConDaR(characteristics=False),
            "no missing": AnaConDaR(missing=False),
            "patch blend alone (ALM)": AnaConDaR(missing=False, anacon=False),
        }.items()
    }
    errors = {label: round(relative(found, target.deltas), 4) for label, found in results.items()}
    print(errors)
    for label, found in results.items():
        assert label == "full" or not np.allclose(found, results["full"])
