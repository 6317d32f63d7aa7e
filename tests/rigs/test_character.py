"""Character-specific targets (`rigs.warp` with a ``character`` step): ground truth, seeding, spec forms."""

from __future__ import annotations

import json
from dataclasses import asdict
from functools import cache

import numpy as np
import pytest
from scipy.spatial import cKDTree

import rigs
import transfer
from rigs._character import REGIONS, Character, region_weights
from rigs._warp import Compose, parse_warp

REFLECT = np.array([-1.0, 1.0, 1.0])


@cache
def template(preset: str = "arkit52") -> rigs.Rig:
    return rigs.generate(preset, seed=1)


@cache
def targets(preset: str = "arkit52") -> tuple[rigs.Rig, rigs.Rig]:
    """The warped target and its character variant."""
    return rigs.warp(template(preset), "alien"), rigs.warp(template(preset), "alien+character")


def _rotated(vectors: np.ndarray, axis: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Rotation matrices built one vertex at a time (independent of the module's Rodrigues formula)."""
    out = np.empty_like(vectors)
    for i, (vector, angle) in enumerate(zip(vectors, angles, strict=True)):
        k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        rotation = np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k
        out[i] = rotation @ vector
    return out


def test_the_recorded_truth_rebuilds_every_shape_from_the_warped_one():
    warped, character = targets()
    truth = character.provenance.character
    assert truth.regions == REGIONS and truth.strength == 1.0 and truth.seed == 0
    weights = region_weights(character)
    traits = truth.traits
    for name in character.names:
        k = character.index(name)
        shape = truth.shapes[name]
        gains = np.exp(weights @ np.array(shape.log_gains))[:, None]
        turned = _rotated(
            warped.deltas[k] * gains, np.array(shape.axis), np.radians(weights @ np.array(shape.angles))
        )
        assert np.allclose(character.deltas[k], turned * np.array(shape.scale), atol=1e-12), name
    expected = np.ones(3)
    expected[0] = traits["smile_width"]
    shape = truth.shapes["mouthSmileLeft"]
    assert np.allclose(shape.scale, 1 + shape.damping * (expected - 1))
    shape = truth.shapes["jawOpen"]
    assert np.allclose(shape.scale, 1 + shape.damping * (traits["jaw_weight"] - 1))


@pytest.mark.parametrize("preset", ["arkit52", "toon"])
def test_no_character_shape_folds_a_triangle(preset):
    warped, character = targets(preset)
    damped = {name: shape.damping for name, shape in character.provenance.character.shapes.items()}
    assert set(damped.values()) <= {1.0, 0.5, 0.25, 0.125, 0.0}
    assert sum(value == 1.0 for value in damped.values()) > 0.7 * len(damped)
    for k in range(character.n_shapes):
        before, after = (rig.neutral + rig.deltas[k] for rig in (warped, character))
        a = _face_normals(before, character.triangles)
        b = _face_normals(after, character.triangles)
        cosine = np.einsum("ij,ij->i", a, b) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
        assert cosine.min() >= np.cos(np.radians(75.0)) - 1e-9, character.names[k]


def _face_normals(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    a, b, c = (points[triangles[:, i]] for i in range(3))
    return np.cross(b - a, c - a)


def test_only_the_displacements_change_and_static_vertices_stay_static():
    warped, character = targets()
    assert np.array_equal(character.neutral, warped.neutral)
    assert np.array_equal(character.triangles, warped.triangles) and character.names == warped.names
    assert np.array_equal((character.deltas != 0).any(axis=2), (warped.deltas != 0).any(axis=2))
    relative = np.linalg.norm(character.deltas - warped.deltas) / np.linalg.norm(warped.deltas)
    assert 0.1 < relative < 0.6
    provenance = json.loads(json.dumps(asdict(character.provenance)))
    assert provenance["warp"]["spec"] == "alien+character"
    assert provenance["source"] == "generated:arkit52 warped by alien+character"


def test_the_actor_has_a_wider_smile_a_heavier_jaw_and_a_stiffer_brow():
    _, character = targets()
    traits = character.provenance.character.traits
    assert 1.2 <= traits["smile_width"] <= 1.4 and 1.15 <= traits["jaw_weight"] <= 1.3
    assert 0.7 <= traits["brow_range"] <= 0.85 and 0.06 <= abs(traits["asymmetry"]) <= 0.12


def test_mirror_twins_stop_being_mirror_images():
    rig = template()
    warped, character = targets()
    _, image = cKDTree(rig.neutral).query(rig.neutral * REFLECT)
    left, right = warped.index("mouthSmileLeft"), warped.index("mouthSmileRight")
    assert np.allclose(warped.deltas[right], warped.deltas[left][image] * REFLECT, atol=1e-9)
    difference = character.deltas[right] - character.deltas[left][image] * REFLECT
    assert np.linalg.norm(difference) > 0.05 * np.linalg.norm(character.deltas[left])


def test_the_same_rig_and_step_give_the_same_target_whatever_the_order_of_the_shapes():
    rig = template()
    again = rigs.warp(template(), "alien+character")
    assert np.array_equal(again.deltas, targets()[1].deltas)
    names = list(reversed(rig.names))
    reordered = rigs.warp(rig.subset(names), "alien+character")
    for name in ("jawOpen", "mouthSmileLeft", "browDownRight"):
        assert np.array_equal(reordered.shape(name), again.shape(name))


def test_seed_and_strength_change_the_character_and_strength_zero_changes_nothing():
    rig, (warped, character) = template(), targets()
    other = rigs.warp(rig, "alien+character:1,7")
    assert not np.allclose(other.deltas, character.deltas)
    assert other.provenance.character.seed == 7
    assert np.array_equal(rigs.warp(rig, "alien+character:0").deltas, warped.deltas)
    mild = rigs.warp(rig, "alien+character:0.5")
    assert np.linalg.norm(mild.deltas - warped.deltas) < np.linalg.norm(character.deltas - warped.deltas)


def test_other_generator_seeds_give_other_actors():
    first = rigs.warp(rigs.generate("tiny", seed=0), "character").provenance.character.traits
    second = rigs.warp(rigs.generate("tiny", seed=5), "character").provenance.character.traits
    assert first != second


def test_deformation_transfer_cannot_know_the_character():
    rig, (warped, character) = template(), targets()
    estimate = transfer.get("dt")(rig, warped.neutral)
    assert transfer.rms(estimate, character.deltas) > 1.5 * transfer.rms(estimate, warped.deltas)


def test_every_geometric_preset_has_a_character_variant():
    geometric = [name for name in rigs.WARPS if "character" not in name]
    assert {f"{name}+character" for name in geometric} | {"character"} | set(geometric) == set(rigs.WARPS)
    spec = rigs.WARPS["alien+character"]
    assert isinstance(spec, Compose) and spec.characters() == [Character()]
    assert len(spec.resolve(template())) == len(rigs.WARPS["alien"].resolve(template()))


@pytest.mark.parametrize(
    ("spec", "expected"),
    [
        ("character", Character()),
        ("character:0.5,3", Character(0.5, 3)),
        ({"kind": "character", "strength": 2, "seed": 1}, Character(2.0, 1)),
        ({"kind": "character"}, Character()),
    ],
)
def test_character_specs_parse(spec, expected):
    assert parse_warp(spec) == expected
    assert parse_warp(expected.label()) == expected
    assert parse_warp(expected.describe()) == expected


def test_a_character_step_applies_after_the_geometry_wherever_it_stands():
    rig = template("tiny")
    assert np.array_equal(
        rigs.warp(rig, "character+big-eyes").deltas, rigs.warp(rig, "big-eyes+character").deltas
    )


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("character:4", r"strength must lie in \[0, 3\]"),
        ("character:-1", "strength must lie"),
        ("character:1,-2", "seed must be a non-negative integer"),
        ("character:1,1.5", "seed must be a non-negative integer"),
        ("character:x", "strength must be a number"),
        ("character:1,2,3", "unknown warp step"),
        ({"kind": "character", "power": 1}, "unknown key 'power'"),
    ],
)
def test_bad_character_specs_are_one_line_errors(spec, message):
    with pytest.raises(ValueError, match=message):
        parse_warp(spec)


def test_a_rig_without_triangles_is_refused():
    rig = template("tiny")
    bare = rigs.Rig(rig.neutral, rig.deltas, np.zeros((0, 3), dtype=int), rig.names)
    with pytest.raises(rigs.RigError, match="needs a triangle mesh"):
        rigs.warp(bare, "character")


def test_region_weights_are_a_smooth_partition_of_unity_that_splits_left_and_right():
    rig = template()
    weights = region_weights(rig)
    assert weights.shape == (rig.n_vertices, len(REGIONS))
    assert np.allclose(weights.sum(axis=1), 1.0) and (weights >= 0).all()
    left = [i for i, name in enumerate(REGIONS) if name.endswith("_L")]
    far_left = rig.neutral[:, 0] > 0.2 * rig.diagonal()
    assert far_left.any() and np.allclose(weights[far_left][:, left].sum(axis=1), 1.0, atol=1e-3)
    bare = rigs.Rig(rig.neutral, rig.deltas, rig.triangles, rig.names)  # no landmarks, no regions
    assert np.allclose(region_weights(bare).sum(axis=1), 1.0)
