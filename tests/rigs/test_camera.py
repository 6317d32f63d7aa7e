"""`rigs.frontal_camera`: the face seen from the front, found from its symmetry plane and moving shapes."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import rigs


def angle(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.degrees(np.arccos(np.clip(a @ b / np.linalg.norm(a) / np.linalg.norm(b), -1, 1))))


def test_faceunits_is_seen_from_its_front_not_from_above(faceunits) -> None:
    right, up, towards = rigs.frontal_camera(faceunits)
    assert angle(right, np.array([1.0, 0, 0])) < 5 and angle(up, np.array([0, 1.0, 0])) < 10
    assert angle(towards, np.array([0, 0, 1.0])) < 10  # the mesh's own front (+z), not its mean normal


@pytest.mark.parametrize("preset", ["digidouble", "toon"])
def test_generated_rigs_are_seen_from_the_front_however_they_are_turned(preset) -> None:
    rig = rigs.generate(preset)
    camera = rigs.frontal_camera(rig)
    assert np.allclose(camera @ camera.T, np.eye(3))
    assert np.allclose(np.cross(camera[0], camera[1]), camera[2])
    assert angle(camera[2], np.array([0, 0, 1.0])) < 8 and angle(camera[1], np.array([0, 1.0, 0])) < 8
    turn = Rotation.from_euler("xyz", [80, 30, -20], degrees=True).as_matrix()  # e.g. a Z-up export, turned
    turned = replace(rig, neutral=rig.neutral @ turn.T, deltas=rig.deltas @ turn.T)
    assert np.allclose(rigs.frontal_camera(turned), camera @ turn.T, atol=1e-6)
    inverted = replace(rig, triangles=rig.triangles[:, ::-1])  # normals pointing inwards: still the front
    assert np.allclose(rigs.frontal_camera(inverted), camera, atol=1e-9)


def test_a_rig_named_left_and_right_is_not_seen_from_behind() -> None:
    rig = rigs.generate("tiny")
    right, _, _ = rigs.frontal_camera(rig)
    left_shapes = [k for k, name in enumerate(rig.names) if rigs.side_of(name) == "L"]
    moved = np.linalg.norm(rig.deltas[left_shapes], axis=2).sum(axis=0)
    centre = (moved @ rig.neutral) / moved.sum()
    assert (centre - rig.neutral.mean(axis=0)) @ right > 0  # the character's left is on the viewer's right


def test_three_quarter_turns_towards_the_characters_left() -> None:
    camera = rigs.frontal_camera(rigs.generate("tiny"))
    quarter = rigs.three_quarter_camera(camera)
    assert angle(quarter[2], camera[2]) == pytest.approx(35.0)
    assert np.allclose(quarter[1], camera[1]) and quarter[2] @ camera[0] > 0
    assert np.allclose(quarter @ quarter.T, np.eye(3))
