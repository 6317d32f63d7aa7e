"""Warps (sec. 5.1): every mesh warped, orientation kept, smooth, invertible, spec forms and errors."""

from __future__ import annotations

import json
from dataclasses import asdict, replace
from functools import cache

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.spatial import cKDTree

import rigs
from rigs import WARPS, Rig, RigError, generate, warp
from rigs._warp import FACTOR_RANGE, Compose, LocalScale, RadialScale, Scale, locate, parse_warp, point_map

REFLECT = np.array([-1.0, 1.0, 1.0])


@cache
def rig_of(preset: str) -> Rig:
    return generate(preset, seed=3)


@cache
def warped(preset: str, name: str) -> Rig:
    return warp(rig_of(preset), name)


def face_normals(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    a, b, c = (points[triangles[:, i]] for i in range(3))
    return np.cross(b - a, c - a)


def min_orientation_cosine(original: Rig, target: Rig) -> float:
    """Smallest cosine between a triangle's normal before and after the warp, over all meshes."""
    worst = 1.0
    for k in range(-1, original.n_shapes):
        before = original.neutral + (original.deltas[k] if k >= 0 else 0.0)
        after = target.neutral + (target.deltas[k] if k >= 0 else 0.0)
        n0, n1 = face_normals(before, original.triangles), face_normals(after, target.triangles)
        cosine = np.einsum("ij,ij->i", n0, n1) / (np.linalg.norm(n0, axis=1) * np.linalg.norm(n1, axis=1))
        worst = min(worst, float(cosine.min()))
    return worst


def jacobian(mapped, points: np.ndarray, step: float = 1e-5) -> np.ndarray:
    """(P, 3, 3) central-difference Jacobians of a point map."""
    columns = []
    for axis in range(3):
        offset = np.zeros(3)
        offset[axis] = step
        columns.append((mapped(points + offset) - mapped(points - offset)) / (2 * step))
    return np.stack(columns, axis=2)


def cube_grid(center: np.ndarray, half: float, count: int) -> np.ndarray:
    axis = np.linspace(-half, half, count)
    return center + np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), axis=-1).reshape(-1, 3)


# -- the warped rig -----------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", list(WARPS))
def test_every_warp_keeps_triangle_orientation_on_every_mesh(name):
    original, target = rig_of("arkit52"), warped("arkit52", name)
    assert min_orientation_cosine(original, target) > 0.0


@pytest.mark.parametrize("preset", ["male", "female"])
def test_alien_keeps_orientation_on_paper_sized_rigs(preset):
    assert min_orientation_cosine(rig_of(preset), warped(preset, "alien")) > 0.0


@pytest.mark.parametrize("name", ["big-eyes", "alien", "scale-x1.3"])
def test_warped_rig_is_a_valid_rig_with_the_same_topology(name):
    original, target = rig_of("tiny"), warped("tiny", name)
    rebuilt = Rig(
        target.neutral,
        target.deltas,
        target.triangles,
        target.names,
        target.regions,
        landmarks=target.landmarks,
        provenance=target.provenance,
        truth=target.truth,
    )
    assert rebuilt.n_vertices == original.n_vertices and rebuilt.n_shapes == original.n_shapes
    assert np.array_equal(target.triangles, original.triangles) and target.names == original.names
    assert all(np.array_equal(target.regions[key], original.regions[key]) for key in original.regions)
    assert not np.allclose(target.neutral, original.neutral)
    provenance = json.loads(json.dumps(asdict(target.provenance)))
    assert provenance["warp"]["spec"] == name and target.truth == original.truth
    assert provenance["source"] == f"generated:tiny warped by {name}" and provenance["units"] == "cm"


def test_deltas_are_differences_of_warped_meshes_and_static_stays_static():
    original, target = rig_of("arkit52"), warped("arkit52", "alien")
    mapped = point_map("alien", original)
    assert np.allclose(target.neutral, mapped(original.neutral))
    for k in (0, 17, original.n_shapes - 1):
        expected = mapped(original.neutral + original.deltas[k]) - mapped(original.neutral)
        assert np.allclose(target.deltas[k], expected, atol=1e-12)
    assert np.array_equal((target.deltas != 0.0).any(axis=2), (original.deltas != 0.0).any(axis=2))


def test_scale_scales_every_delta_per_axis():
    original, target = rig_of("tiny"), warp(rig_of("tiny"), "scale:1.3,0.9,1.1")
    assert np.allclose(target.deltas, original.deltas * [1.3, 0.9, 1.1], atol=1e-12)
    low, high = original.bounding_box()
    assert np.allclose(0.5 * sum(target.bounding_box()), 0.5 * (low + high))


@pytest.mark.parametrize("name", ["scale-x1.3", "big-eyes", "small-mouth", "alien"])
def test_symmetric_warps_keep_the_rig_exactly_mirror_symmetric(name):
    original, target = rig_of("tiny"), warped("tiny", name)
    distance, image = cKDTree(original.neutral).query(original.neutral * REFLECT)
    assert distance.max() == 0.0
    assert np.array_equal(target.neutral[image], target.neutral * REFLECT)
    pairs = target.truth.mirror_pairs
    for left, right in pairs:
        assert np.array_equal(
            target.deltas[target.index(right)], target.deltas[target.index(left)][image] * REFLECT
        )


def test_big_eyes_enlarges_the_eyes_and_leaves_the_chin():
    original, target = rig_of("female"), warped("female", "big-eyes")
    lids = np.concatenate([original.regions["upper_eyelid_L"], original.regions["lower_eyelid_L"]])
    spread = np.ptp(target.neutral[lids], axis=0) / np.ptp(original.neutral[lids], axis=0)
    assert spread[0] > 1.1 and spread[1] > 1.1
    chin = original.neutral[:, 1] < original.landmarks["mouth"][1] - 2.0
    assert np.array_equal(target.neutral[chin], original.neutral[chin])


def test_composition_carries_later_centres_along():
    original = rig_of("female")
    target = warp(original, [{"kind": "scale", "factors": [1.0, 1.5, 1.0]}, "big-mouth"])
    moved = np.array(target.landmarks["mouth"])
    assert np.allclose(moved, point_map("scale:1,1.5,1", original)(np.array(original.landmarks["mouth"])))
    lips = np.concatenate([original.regions["upper_lip"], original.regions["lower_lip"]])
    assert np.linalg.norm(target.neutral[lips].mean(axis=0) - moved) < 1.0


def test_warp_is_deterministic():
    first, second = warp(rig_of("tiny"), "alien"), warp(rig_of("tiny"), "alien")
    assert (
        first.neutral.tobytes() == second.neutral.tobytes()
        and first.deltas.tobytes() == second.deltas.tobytes()
    )


# -- spec forms ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("spec", "equivalent"),
    [
        ("scale-x1.3", "scale:1.3,1,1"),
        ("scale-x1.3", {"kind": "scale", "factors": [1.3, 1, 1]}),
        ("scale-x1.3", Scale((1.3, 1.0, 1.0))),
        ("small-mouth", {"kind": "local", "center": "mouth", "factor": 0.7}),
        ("big-eyes", "local:eye_L,1.4+local:eye_R,1.4"),
        ("big-eyes", [LocalScale("eye_L", 1.4), {"kind": "local", "center": "eye_R", "factor": 1.4}]),
        ("big-eyes+small-mouth", {"kind": "compose", "steps": ["big-eyes", "small-mouth"]}),
    ],
)
def test_spec_forms_agree(spec, equivalent):
    rig = rig_of("tiny")
    first, second = warp(rig, spec), warp(rig, equivalent)
    assert np.allclose(first.neutral, second.neutral, atol=1e-12)
    assert np.allclose(first.deltas, second.deltas, atol=1e-12)


@pytest.mark.parametrize(
    "spec",
    [
        [
            {"kind": "scale", "factors": [1.3, 1, 1]},
            {"kind": "local", "center": [0, -4, 1], "factor": 0.7, "radius": 2},
        ],
        {"kind": "local", "center": "mouth", "factor": 0.7, "radius_rel": 0.1},
        WARPS["alien"],
    ],
)
def test_recorded_label_reproduces_the_warp(spec):
    rig = rig_of("tiny")
    first = warp(rig, spec)
    again = warp(rig, first.provenance.warp.spec)
    assert parse_warp(first.provenance.warp.spec) == parse_warp(spec)
    assert np.array_equal(first.neutral, again.neutral) and np.array_equal(first.deltas, again.deltas)


def test_explicit_centre_and_radius_work_on_a_rig_without_landmarks_or_regions():
    plain = replace(rig_of("tiny"), regions={}, landmarks={}, provenance=rigs.Provenance(source="plain.npz"))
    mouth = rig_of("tiny").landmarks["mouth"]
    target = warp(plain, {"kind": "local", "center": mouth, "factor": 0.7, "radius": 2.5})
    moved = np.linalg.norm(target.neutral - plain.neutral, axis=1) > 0
    assert moved.any() and (np.linalg.norm(plain.neutral[moved] - mouth, axis=1) < 2.5).all()


@pytest.mark.parametrize("name", ["alien", "big-nose"])
def test_a_rig_saved_without_landmarks_warps_identically_from_its_regions(name):
    """The native format keeps regions but not landmarks: named centres then come from the regions, and the
    generated landmarks are exactly those region centroids."""
    rig = rig_of("female")
    without = replace(rig, landmarks={}, truth=None, provenance=rigs.Provenance(source="female.npz"))
    for landmark, point in rig.landmarks.items():
        assert np.array_equal(locate(without, landmark), point)
    target, reference = warp(without, name), warped("female", name)
    assert np.array_equal(target.neutral, reference.neutral) and np.array_equal(
        target.deltas, reference.deltas
    )


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("bulge", "unknown warp step 'bulge'; use a preset (scale-x1.3"),
        ("scale:1,2", "unknown warp step 'scale:1,2'"),
        ("scale:1,0,1", "scale factor must be a positive number, got '0'"),
        ("local:mouth,3.0", "local factor must lie in [0.35, 2.0] to stay invertible, got '3.0'"),
        ({"kind": "local", "center": "mouth"}, "local warp: missing key 'factor'"),
        ({"kind": "local", "center": "mouth", "factor": 0.7, "size": 2}, "local warp: unknown key 'size'"),
        ({"kind": "twist"}, "warp dict needs 'kind' of scale, local or compose, got 'twist'"),
        (
            {"kind": "local", "center": [0, 1], "factor": 0.7},
            "local center must be a name or three coordinates",
        ),
        (
            {"kind": "local", "center": "mouth", "factor": 0.7, "radius": -1},
            "local radius must be a positive",
        ),
        (42, "warp spec must be a preset name, a string, a dict, a list or a Warp, got 42"),
        ({"kind": "scale", "factors": 1.3}, "scale factors must be three positive numbers, got 1.3"),
    ],
)
def test_bad_specs_raise_one_clear_error(spec, message):
    with pytest.raises(ValueError, match=message.replace("[", r"\[").replace("(", r"\(")):
        warp(rig_of("tiny"), spec)


def test_unlocatable_centre_names_what_is_missing():
    plain = replace(rig_of("tiny"), regions={}, landmarks={}, provenance=rigs.Provenance(source="scan.obj"))
    with pytest.raises(RigError, match=r"scan\.obj: cannot locate 'nose' for the warp: no landmark 'nose'"):
        warp(plain, "big-nose")
    with pytest.raises(RigError, match="no non-empty region 'upper_eyelid_L' and 'lower_eyelid_L'"):
        warp(plain, "big-eyes")


def test_presets_are_exported():
    assert {"scale-x1.3", "big-eyes", "small-mouth", "alien"} <= set(rigs.WARPS)
    assert isinstance(WARPS["alien"], Compose)


# -- the local map: smooth, invertible, identity outside ---------------------------------------------------

factors = st.floats(*FACTOR_RANGE)
radii = st.floats(0.5, 5.0)


@settings(max_examples=40, deadline=None)
@given(factor=factors, radius=radii)
def test_local_map_is_orientation_preserving_on_a_grid(factor, radius):
    local = RadialScale(np.array([0.3, -0.2, 0.1]), radius, factor)
    points = cube_grid(local.center, 1.2 * radius, 15)
    determinant = np.linalg.det(jacobian(local, points, step=1e-6 * radius))
    assert determinant.min() > 0.0


@settings(max_examples=40, deadline=None)
@given(factor=factors, radius=radii)
def test_local_map_is_invertible_on_a_grid(factor, radius):
    """The map is radial with a strictly increasing profile, so bisection on the radius inverts it."""
    local = RadialScale(np.zeros(3), radius, factor)
    points = cube_grid(np.zeros(3), 1.3 * radius, 11)
    images = local(points)
    target = np.linalg.norm(images, axis=1)
    profile = np.linspace(0.0, 1.3 * radius, 2001)
    mapped_profile = np.linalg.norm(local(np.column_stack([profile, 0 * profile, 0 * profile])), axis=1)
    assert np.all(np.diff(mapped_profile) > 0)  # r -> r (1 + (f - 1) g(r)) strictly increasing
    low, high = np.zeros_like(target), target / FACTOR_RANGE[0]
    for _ in range(60):
        middle = 0.5 * (low + high)
        below = np.linalg.norm(local(np.column_stack([middle, 0 * middle, 0 * middle])), axis=1) < target
        low, high = np.where(below, middle, low), np.where(below, high, middle)
    direction = images / np.maximum(target, 1e-300)[:, None]
    recovered = direction * (0.5 * (low + high))[:, None]
    assert np.allclose(recovered, points, atol=1e-9 * radius)
    assert len(np.unique(images.round(12), axis=0)) == len(points)


@pytest.mark.parametrize("factor", [FACTOR_RANGE[0], 0.7, 1.6, FACTOR_RANGE[1]])
def test_local_map_is_smooth_across_its_rim(factor):
    """Second differences along a ray converge as the step shrinks (no kink, which would make them grow
    like 1/step) and vanish at the rim, where the map meets the identity (C2)."""
    local = RadialScale(np.zeros(3), 1.0, factor)
    ray = np.array([0.6, 0.0, 0.8])
    radius = np.linspace(0.0, 1.5, 6001)

    def curvature(step: float) -> np.ndarray:
        points = radius[:, None] * ray
        second = local(points + step * ray) - 2 * local(points) + local(points - step * ray)
        return np.linalg.norm(second, axis=1) / step**2

    coarse, fine = curvature(1e-2).max(), curvature(1e-3)
    assert abs(coarse - fine.max()) < 0.05 * fine.max()
    assert fine[np.abs(radius - 1.0) < 1e-3].max() < 0.03 * fine.max()


def test_local_map_is_the_identity_outside_its_ball():
    local = RadialScale(np.array([1.0, 2.0, 3.0]), 2.0, 1.8)
    rng = np.random.default_rng(0)
    directions = rng.normal(size=(500, 3))
    points = local.center + directions / np.linalg.norm(directions, axis=1, keepdims=True) * rng.uniform(
        2, 5, (500, 1)
    )
    assert np.array_equal(local(points), points)
