"""Procedural rigs: sizes, determinism, exact symmetry, planted symmetry truth, Fig. 2 vertex split."""

from __future__ import annotations

import json
from dataclasses import asdict
from functools import cache

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.spatial import cKDTree

import rigs
from rigs import PRESETS, Rig, generate
from rigs._generate import PresetSpec

MU = 0.3  # eq. 2
REFLECT = np.array([-1.0, 1.0, 1.0])
REGION_PAIRS = (
    ("upper_lip", "lower_lip"),
    ("upper_eyelid_L", "lower_eyelid_L"),
    ("upper_eyelid_R", "lower_eyelid_R"),
)
ARKIT_52 = {
    *(f"eye{part}{side}" for part in ("Blink", "LookDown", "LookIn", "LookOut", "LookUp", "Squint", "Wide")
      for side in ("Left", "Right")),
    "jawForward", "jawLeft", "jawRight", "jawOpen",
    "mouthClose", "mouthFunnel", "mouthPucker", "mouthLeft", "mouthRight",
    *(f"mouth{part}{side}" for side in ("Left", "Right")
      for part in ("Smile", "Frown", "Dimple", "Stretch", "Press", "LowerDown", "UpperUp")),
    "mouthRollLower", "mouthRollUpper", "mouthShrugLower", "mouthShrugUpper",
    "browDownLeft", "browDownRight", "browInnerUp", "browOuterUpLeft", "browOuterUpRight",
    "cheekPuff", "cheekSquintLeft", "cheekSquintRight", "noseSneerLeft", "noseSneerRight", "tongueOut",
}  # fmt: skip


@cache
def rig_of(preset: str, seed: int = 0) -> Rig:
    return generate(preset, seed=seed)


# -- independent reference checks, straight from the paper's equations -------------------------------------


def mirror_vertices(neutral: np.ndarray) -> np.ndarray:
    """Exact mirror vertex of every vertex (sec. 4.4.1); fails when one is missing."""
    distance, index = cKDTree(neutral).query(neutral * REFLECT)
    assert distance.max() == 0.0, f"vertex {int(distance.argmax())} has no exact mirror vertex"
    return index


def binary(deltas: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Active masks (eq. 2) and displacement lengths."""
    norms = np.linalg.norm(deltas, axis=2)
    return norms >= MU * norms.max(axis=1, keepdims=True), norms


def mirror_errors(deltas: np.ndarray, masks: np.ndarray, norms: np.ndarray, mirror: np.ndarray) -> np.ndarray:
    """``eps[k, m]`` of eq. 9 (the mask is mirrored with the displacement); inf where the masks miss."""
    reflected, mirrored_masks, mirrored_norms = (
        deltas[:, mirror] * REFLECT,
        masks[:, mirror],
        norms[:, mirror],
    )
    own, other = (norms * masks).sum(axis=1), (mirrored_norms * mirrored_masks).sum(axis=1)
    overlap = masks.astype(float) @ mirrored_masks.T.astype(float)
    errors = np.full(overlap.shape, np.inf)
    for k in range(len(deltas)):  # one row of eq. 9 per shape, vectorised over partners and vertices
        partners, vertices = np.flatnonzero(overlap[k]), np.flatnonzero(masks[k])
        difference = np.linalg.norm(deltas[k, vertices] - reflected[partners][:, vertices], axis=2)
        both = mirrored_masks[partners][:, vertices]
        correction = np.where(
            both, difference - norms[k, vertices] - mirrored_norms[partners][:, vertices], 0.0
        )
        errors[k, partners] = (own[k] + other[partners] + correction.sum(axis=1)) / overlap[k, partners]
    return errors


def greedy_match(candidates: list[tuple[float, int, int]]) -> list[tuple[int, int]]:
    taken: set[int] = set()
    pairs = []
    for _, a, b in sorted(candidates):
        if a not in taken and b not in taken:
            taken |= {a, b}
            pairs.append((a, b))
    return pairs


def shape_symmetry(rig: Rig) -> tuple[np.ndarray, list[tuple[int, int]]]:
    """Self-symmetric shapes (eq. 9 with m = k below eq. 10's bound) and mirror pairs (eqs. 9-10), the
    lowest error first, each shape in at most one pair; a match whose shapes share more than 15% of the
    smaller one's active vertices farther from the plane x = 0 than a quarter of the pair's reach is
    refused (sec. 4.4.1: it spreads over both halves)."""
    masks, norms = binary(rig.deltas)
    errors = mirror_errors(rig.deltas, masks, norms, mirror_vertices(rig.neutral))
    largest = norms.max(axis=1)
    self_symmetric = np.diag(errors) < 0.4 * largest
    score = np.maximum(errors, errors.T)
    below = score < 0.4 * np.minimum.outer(largest, largest)
    below &= ~self_symmetric[:, None] & ~self_symmetric[None, :]
    first, second = np.nonzero(np.triu(below, k=1))
    matched = greedy_match([(score[a, b], a, b) for a, b in zip(first, second, strict=True)])
    distance = np.abs(rig.neutral[:, 0])
    kept = []
    for a, b in matched:
        reach = distance[masks[a] | masks[b]].max()
        off_axis = masks[a] & masks[b] & (distance > 0.25 * reach)
        if off_axis.sum() <= 0.15 * min(masks[a].sum(), masks[b].sum()):
            kept.append((a, b))
    return self_symmetric, kept


def motion_symmetry(rig: Rig, excluded: set[int], share: float) -> list[tuple[int, int]]:
    """Motion pairs (eqs. 11-12) among the shapes not ``excluded``: a candidate has active vertices in
    exactly one sketch region, at least ``share`` of them there; smallest angle first."""
    masks, _ = binary(rig.deltas)
    names = [name for pair in REGION_PAIRS for name in pair]
    counts = np.column_stack([masks[:, rig.regions[name]].sum(axis=1) for name in names])
    single = (counts > 0).sum(axis=1) == 1
    summed = np.einsum("kn,knd->kd", masks.astype(float), rig.deltas)
    direction = summed / np.linalg.norm(summed, axis=1, keepdims=True)
    candidates = []
    for upper, lower in REGION_PAIRS:
        pick = {}
        for side in (upper, lower):
            inside = counts[:, names.index(side)]
            chosen = single & (inside > 0) & (inside >= share * masks.sum(axis=1))
            pick[side] = [k for k in np.flatnonzero(chosen) if k not in excluded]
        for k in pick[upper]:
            for m in pick[lower]:
                cosine = float(direction[k] @ direction[m])
                if cosine < -0.985:
                    candidates.append((cosine, k, m))
    return greedy_match(candidates)


def detect_symmetry(rig: Rig, share: float, mirror_paired_may_move: bool = False) -> dict[str, set]:
    """Symmetry of sec. 4.4 as a detector following the paper would find it. Motion pairs are sought
    among the shapes left unpaired, or, with ``mirror_paired_may_move``, among all shapes."""
    self_symmetric, mirror_pairs = shape_symmetry(rig)
    excluded = set() if mirror_paired_may_move else {k for pair in mirror_pairs for k in pair}
    label = rig.names
    return {
        "self_symmetric": {label[k] for k in np.flatnonzero(self_symmetric)},
        "mirror_pairs": {frozenset((label[a], label[b])) for a, b in mirror_pairs},
        "motion_pairs": {(label[a], label[b]) for a, b in motion_symmetry(rig, excluded, share)},
    }


def truth_sets(rig: Rig) -> dict[str, set]:
    truth = rig.truth
    return {
        "self_symmetric": set(truth.self_symmetric),
        "mirror_pairs": {frozenset(pair) for pair in truth.mirror_pairs},
        "motion_pairs": {tuple(pair) for pair in truth.motion_pairs},
    }


# -- sizes and metadata -------------------------------------------------------------------------------------


@pytest.mark.parametrize("preset", list(PRESETS))
def test_preset_sizes_match_the_paper(preset):
    rig, spec = rig_of(preset), PRESETS[preset]
    assert abs(rig.n_vertices - spec.n_vertices) <= 0.02 * spec.n_vertices
    assert rig.n_shapes == spec.n_shapes
    assert len(set(rig.names)) == rig.n_shapes
    assert rig.n_triangles > rig.n_vertices
    assert len(rig.degenerate_triangles()) == 0


def test_paper_sizes_are_the_presets():
    sizes = {name: (spec.n_vertices, spec.n_shapes) for name, spec in PRESETS.items()}
    assert sizes["male"] == (7366, 73)
    assert sizes["toon"] == (11680, 65)
    assert sizes["female"] == (5034, 265)
    assert sizes["digidouble"] == (5131, 161)
    assert sizes["arkit52"][1] == 52
    assert 200 <= sizes["tiny"][0] < 1000 and sizes["tiny"][1] == 12


@pytest.mark.parametrize("preset", ["tiny", "female"])
def test_records_hold_the_provenance_and_are_json(preset):
    rig = generate(preset, seed=7)
    records = {**asdict(rig.provenance), "landmarks": rig.landmarks, "truth": asdict(rig.truth)}
    written = json.loads(json.dumps(records))
    assert written["source"] == f"generated:{preset}"
    assert written["generator"] == {"preset": preset, "seed": 7} and written["units"] == "cm"
    assert set(written["landmarks"]) == {"eye_L", "eye_R", "mouth", "nose"}
    assert set(written["truth"]) == {"mirror_pairs", "spread_mirror_images", "motion_pairs", "self_symmetric"}
    assert len(json.dumps(records)) < 20_000


def test_arkit52_has_the_arkit_names_and_their_mirror_pairs():
    rig = rig_of("arkit52")
    assert set(rig.names) == ARKIT_52
    pairs = {tuple(pair) for pair in rig.truth.mirror_pairs}
    spread = {tuple(pair) for pair in rig.truth.spread_mirror_images}
    assert ("eyeBlinkLeft", "eyeBlinkRight") in pairs and ("jawLeft", "jawRight") not in pairs
    assert spread == {("jawLeft", "jawRight"), ("mouthLeft", "mouthRight")}
    assert all(left.replace("Left", "Right") == right for left, right in pairs | spread)
    assert len(pairs) == 18 and len(rig.truth.self_symmetric) == 12
    assert {"jawOpen", "mouthFunnel", "browInnerUp", "cheekPuff"} <= set(rig.truth.self_symmetric)


@pytest.mark.parametrize("preset", ["male", "toon", "female", "digidouble"])
def test_facs_presets_have_subtle_variants_and_large_shapes(preset):
    rig = rig_of(preset)
    smiles = [name for name in rig.names if name.startswith("mouthSmile") and name.endswith("_L")]
    assert len(smiles) >= 3
    masks, _ = binary(rig.deltas)
    active = masks.sum(axis=1)
    for large in ("happy", "sad", "halfSmile_L", "jawOpen"):
        assert active[rig.index(large)] > 2 * np.median(active), large


def test_custom_spec_builds_requested_size():
    rig = generate(PresetSpec("custom", 900, 31, "a custom size"), seed=2)
    assert abs(rig.n_vertices - 900) <= 18 and rig.n_shapes == 31
    assert rig.provenance.source == "generated:custom"


@pytest.mark.parametrize(
    ("preset", "seed", "message"),
    [
        ("nope", 0, "unknown rig preset 'nope'; choose one of: male, toon"),
        ("tiny", -1, "seed must be a non-negative integer, got -1"),
        ("tiny", 1.5, "seed must be a non-negative integer, got 1.5"),
        (PresetSpec("small", 50, 3, ""), 0, "preset 'small': need n_vertices >= 200"),
    ],
)
def test_bad_arguments_raise_one_clear_error(preset, seed, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(")):
        generate(preset, seed=seed)


# -- determinism --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("preset", ["tiny", "arkit52", "digidouble"])
def test_same_seed_gives_the_same_rig_bit_for_bit(preset):
    first, second = generate(preset, seed=11), generate(preset, seed=11)
    for field in ("neutral", "deltas", "triangles"):
        assert getattr(first, field).tobytes() == getattr(second, field).tobytes()
    assert first.names == second.names and first.provenance == second.provenance
    assert first.landmarks == second.landmarks and first.truth == second.truth
    assert first.regions.keys() == second.regions.keys()
    assert all(np.array_equal(first.regions[name], second.regions[name]) for name in first.regions)


def test_different_seeds_move_and_resize_shapes():
    first, second = rig_of("male", 0), rig_of("male", 1)
    assert first.names == second.names and np.array_equal(first.neutral, second.neutral)
    masks_first, norms_first = binary(first.deltas)
    masks_second, norms_second = binary(second.deltas)
    differs = np.any(masks_first != masks_second, axis=1)
    assert differs.mean() > 0.5
    assert not np.allclose(norms_first.max(axis=1), norms_second.max(axis=1))


# -- geometry -----------------------------------------------------------------------------------------------


@pytest.mark.parametrize("preset", list(PRESETS))
def test_neutral_and_triangulation_are_mirror_symmetric(preset):
    rig = rig_of(preset)
    mirror = mirror_vertices(rig.neutral)
    assert np.array_equal(mirror[mirror], np.arange(rig.n_vertices))
    triangles = {tuple(sorted(face)) for face in rig.triangles.tolist()}
    assert {tuple(sorted(face)) for face in mirror[rig.triangles].tolist()} == triangles


def boundary_loops(triangles: np.ndarray) -> int:
    """Number of boundary loops (outer rim plus holes) of a triangle mesh."""
    edges = np.sort(
        np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1
    )
    unique, counts = np.unique(edges, axis=0, return_counts=True)
    boundary = unique[counts == 1]
    parent = {int(v): int(v) for v in boundary.ravel()}

    def root(v: int) -> int:
        while parent[v] != v:
            parent[v] = parent[parent[v]]
            v = parent[v]
        return v

    for a, b in boundary.tolist():
        parent[root(a)] = root(b)
    return len({root(v) for v in parent})


@pytest.mark.parametrize("preset", ["tiny", "arkit52", "female"])
def test_face_has_eye_and_mouth_openings_nose_and_sockets(preset):
    rig = rig_of(preset)
    assert boundary_loops(rig.triangles) == 4  # outer rim, two eyes, mouth
    landmarks = {name: np.array(point) for name, point in rig.landmarks.items()}
    x, y, z = rig.neutral.T
    tip = int(z.argmax())
    assert abs(x[tip]) < 0.6 and landmarks["mouth"][1] < y[tip] < landmarks["eye_L"][1]
    assert z[tip] - np.median(z) > 1.5  # the nose stands out of the face
    near_eye = np.linalg.norm(rig.neutral[:, :2] - landmarks["eye_L"][:2], axis=1) < 3.0
    assert landmarks["eye_L"][2] < np.median(
        z[near_eye & (y > landmarks["eye_L"][1] + 1.8)]
    )  # socket below brow
    assert np.allclose(landmarks["eye_R"], landmarks["eye_L"] * REFLECT)


@pytest.mark.parametrize("preset", list(PRESETS))
def test_regions_are_mirrored_disjoint_sketches(preset):
    rig = rig_of(preset)
    mirror = mirror_vertices(rig.neutral)
    assert set(rig.regions) == {name for pair in REGION_PAIRS for name in pair} | {"nose"}
    assert np.array_equal(np.sort(mirror[rig.regions["nose"]]), rig.regions["nose"])
    for upper, lower in REGION_PAIRS:
        assert len(rig.regions[upper]) and len(rig.regions[lower])
        assert not np.intersect1d(rig.regions[upper], rig.regions[lower]).size
    for part in ("upper_eyelid", "lower_eyelid"):
        assert np.array_equal(np.sort(mirror[rig.regions[f"{part}_L"]]), rig.regions[f"{part}_R"])
    assert np.array_equal(np.sort(mirror[rig.regions["upper_lip"]]), rig.regions["upper_lip"])


# -- shapes -------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("preset", list(PRESETS))
def test_every_shape_has_static_smoothing_and_active_vertices(preset):
    """Fig. 2: static (exactly 0), smoothing (below mu of the max) and active vertices; none empty."""
    rig = rig_of(preset)
    masks, norms = binary(rig.deltas)
    assert norms.max(axis=1).min() > 0.05  # no empty shape (cm)
    static = norms == 0.0
    smoothing = ~static & ~masks
    for kind, mask in (("static", static), ("smoothing", smoothing), ("active", masks)):
        missing = [rig.names[k] for k in np.flatnonzero(~mask.any(axis=1))]
        assert not missing, f"{preset}: shapes without {kind} vertices: {missing}"


def test_shape_directions_vary():
    rig = rig_of("female")
    masks, _ = binary(rig.deltas)
    summed = np.einsum("kn,knd->kd", masks.astype(float), rig.deltas)
    direction = summed / np.linalg.norm(summed, axis=1, keepdims=True)
    dominant = np.abs(direction).argmax(axis=1)
    assert np.bincount(dominant, minlength=3).min() >= 0.1 * rig.n_shapes  # x, y and z all dominate somewhere
    assert (direction[:, 1] > 0.7).any() and (direction[:, 1] < -0.7).any()


@pytest.mark.parametrize("preset", list(PRESETS))
def test_truth_mirror_pairs_and_self_symmetric_shapes_are_exact(preset):
    rig = rig_of(preset)
    mirror = mirror_vertices(rig.neutral)
    truth = rig.truth
    for left, right in truth.mirror_pairs + truth.spread_mirror_images:
        assert np.array_equal(rig.deltas[rig.index(right)], rig.deltas[rig.index(left)][mirror] * REFLECT)
    for name in truth.self_symmetric:
        delta = rig.deltas[rig.index(name)]
        assert np.array_equal(delta, delta[mirror] * REFLECT), name
    grouped = [name for pair in truth.mirror_pairs + truth.motion_pairs for name in pair]
    assert len(grouped) == len(set(grouped)), "a shape joins at most one symmetry pair"
    assert not {name for pair in truth.mirror_pairs for name in pair} & set(truth.self_symmetric)


@pytest.mark.parametrize("preset", list(PRESETS))
def test_truth_motion_pairs_are_opposite_and_confined_to_one_region_pair(preset):
    rig = rig_of(preset)
    masks, _ = binary(rig.deltas)
    assert rig.truth.motion_pairs or preset == "arkit52"
    for upper, lower in rig.truth.motion_pairs:
        k, m = rig.index(upper), rig.index(lower)
        homes = [
            pair
            for pair in REGION_PAIRS
            if np.isin(np.flatnonzero(masks[k]), rig.regions[pair[0]]).all()
            and np.isin(np.flatnonzero(masks[m]), rig.regions[pair[1]]).all()
        ]
        assert len(homes) == 1, (upper, lower)
        directions = [rig.deltas[s][masks[s]].sum(axis=0) for s in (k, m)]
        cosine = directions[0] @ directions[1] / np.prod([np.linalg.norm(d) for d in directions])
        assert cosine < -0.985, (upper, lower, cosine)


@cache
def detected_shape_symmetry(preset: str) -> dict[str, set]:
    rig = rig_of(preset)
    self_symmetric, mirror_pairs = shape_symmetry(rig)
    return {
        "self_symmetric": {rig.names[k] for k in np.flatnonzero(self_symmetric)},
        "mirror_pairs": {frozenset((rig.names[a], rig.names[b])) for a, b in mirror_pairs},
    }


@pytest.mark.parametrize("preset", ["tiny", "arkit52", "male", "toon", "digidouble", "female"])
def test_shape_symmetry_detection_finds_exactly_the_truth(preset):
    """Eqs. 9-10 find every planted mirror pair and self-symmetric shape, and nothing else."""
    truth = truth_sets(rig_of(preset))
    assert detected_shape_symmetry(preset) == {key: truth[key] for key in ("self_symmetric", "mirror_pairs")}


@pytest.mark.parametrize("mirror_paired_may_move", [False, True])
@pytest.mark.parametrize("share", [0.0, 0.5])
@pytest.mark.parametrize("preset", ["tiny", "arkit52", "male", "toon", "digidouble", "female"])
def test_motion_symmetry_detection_finds_exactly_the_truth(preset, share, mirror_paired_may_move):
    """Eqs. 11-12 find the planted motion pairs and nothing else, whether a candidate needs half of its
    active vertices in its sketch or merely touches one sketch only, and whether shapes already in a
    mirror pair may also form motion pairs."""
    rig = rig_of(preset)
    pairs = detected_shape_symmetry(preset)["mirror_pairs"]
    excluded = set() if mirror_paired_may_move else {rig.index(name) for pair in pairs for name in pair}
    found = {(rig.names[a], rig.names[b]) for a, b in motion_symmetry(rig, excluded, share)}
    assert found == truth_sets(rig)["motion_pairs"]


@settings(max_examples=12, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    preset=st.sampled_from(["tiny", "arkit52"]),
    share=st.sampled_from([0.0, 0.5]),
    mirror_paired_may_move=st.booleans(),
)
def test_symmetry_truth_holds_for_any_seed(seed, preset, share, mirror_paired_may_move):
    rig = generate(preset, seed=seed)
    assert detect_symmetry(rig, share, mirror_paired_may_move) == truth_sets(rig)


def test_rig_satisfies_the_public_contract():
    rig = rig_of("tiny")
    assert isinstance(rig, rigs.Rig)
    assert not rig.deltas.flags.writeable
    assert rig.truth.motion_pairs == (
        ("upperLipRaise", "lowerLipDepress"),
        ("eyeUpperLidPress_L", "eyeLowerLidPress_L"),
        ("eyeUpperLidPull_R", "eyeLowerLidPull_R"),
    )
