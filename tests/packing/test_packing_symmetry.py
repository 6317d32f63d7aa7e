"""Shape symmetry (eqs. 9-10) and motion symmetry (eqs. 11-12), on built rigs and generated presets."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

import packing
import rigs


def _as_sets(pairs):
    return {frozenset(pair) for pair in pairs}


def test_face_pairs_match_the_truth(face):
    rig, truth = face
    pairs = packing.find_symmetry_pairs(rig)
    assert _as_sets(pairs) == _as_sets(truth["mirror_pairs"] + truth["motion_pairs"])
    analysis = packing.analyse(rig, rig.neutral)
    assert set(analysis.self_symmetric) == set(truth["self_symmetric"])
    assert _as_sets(analysis.pairs[: len(truth["mirror_pairs"])]) == _as_sets(truth["mirror_pairs"])


def test_pairs_survive_noise_and_an_unsymmetric_vertex_order(face, kit):
    rig, truth = kit.standard_face(jitter=0.002, seed=4)
    order = np.random.default_rng(1).permutation(rig.n_vertices)
    inverse = np.argsort(order)
    shuffled = dataclasses.replace(
        rig,
        neutral=rig.neutral[order],
        deltas=rig.deltas[:, order],
        triangles=inverse[rig.triangles],
        regions={name: inverse[index] for name, index in rig.regions.items()},
    )
    assert _as_sets(packing.find_symmetry_pairs(shuffled)) == _as_sets(
        truth["mirror_pairs"] + truth["motion_pairs"]
    )


def test_switches(face):
    rig, truth = face
    assert _as_sets(packing.find_symmetry_pairs(rig, motion=False)) == _as_sets(truth["mirror_pairs"])
    assert _as_sets(packing.find_symmetry_pairs(rig, shape=False)) == _as_sets(truth["motion_pairs"])
    assert packing.find_symmetry_pairs(rig, shape=False, motion=False) == []
    assert packing.analyse(rig, rig.neutral, symmetry=False).pairs == ()


def test_self_symmetric_shapes_are_never_mirror_pairs(kit):
    # Two copies of a symmetric shape: identical, each the mirror of the other, but self-symmetric.
    centre = kit.Bump("jawOpen", (0.0, -0.8), (0.3, 0.1), (0.0, -1.0, 0.0))
    twin = dataclasses.replace(centre, name="jawOpen2")
    rig = kit.face_rig([centre, twin], regions={})
    assert packing.find_symmetry_pairs(rig) == []
    analysis = packing.analyse(rig, rig.neutral)
    assert analysis.self_symmetric == ("jawOpen", "jawOpen2")


def test_lowest_error_wins_and_each_shape_joins_one_pair(kit):
    right = kit.Bump("smile_R", (0.4, -0.5), (0.12, 0.1), (0.6, 0.7, 0.1))
    left = kit.mirrored(right, "smile_L")
    near = dataclasses.replace(left, name="smileSoft_L", amplitude=0.85)  # a weaker variant of the mirror
    rig = kit.face_rig([right, near, left], regions={})
    assert packing.find_symmetry_pairs(rig) == [("smile_R", "smile_L")]
    assert packing.find_symmetry_pairs(
        dataclasses.replace(rig, deltas=rig.deltas[:2], names=rig.names[:2])
    ) == [("smile_R", "smileSoft_L")]


def test_eq10_threshold_rejects_different_shapes(kit):
    right = kit.Bump("brow_R", (0.5, 0.8), (0.15, 0.08), (0.0, 1.0, 0.0))
    other = kit.Bump("brow_L", (-0.5, 0.8), (0.15, 0.08), (0.0, 0.0, 1.0))  # mirrored place, other motion
    rig = kit.face_rig([right, other], regions={})
    assert packing.find_symmetry_pairs(rig) == []
    assert packing.find_symmetry_pairs(rig, shape_tol=2.0) == [("brow_R", "brow_L")]


def test_motion_pairs_need_opposite_directions(kit, face):
    rig, _ = face
    up = kit.Bump("upperLipUp", (0.0, -0.48), (0.25, 0.03), (0.0, 1.0, 0.0))
    sideways = kit.Bump("lowerLipSide", (0.0, -0.66), (0.25, 0.03), (0.2, -1.0, 0.0))  # cos = -0.98 > -0.985
    down = kit.Bump("lowerLipDown", (0.0, -0.66), (0.25, 0.03), (0.05, -1.0, 0.0))  # cos = -0.9988
    lips = kit.face_rig([up, sideways, down], regions=kit.FACE_REGIONS)
    assert packing.find_symmetry_pairs(lips, shape=False) == [("upperLipUp", "lowerLipDown")]
    assert packing.find_symmetry_pairs(lips, shape=False, motion_cos=-0.9) == [("upperLipUp", "lowerLipDown")]
    without_down = dataclasses.replace(lips, deltas=lips.deltas[:2], names=lips.names[:2])
    assert packing.find_symmetry_pairs(without_down, shape=False) == []
    assert packing.find_symmetry_pairs(without_down, shape=False, motion_cos=-0.9) == [
        ("upperLipUp", "lowerLipSide")
    ]


def test_motion_candidates_touch_exactly_one_sketch(kit):
    up = kit.Bump("upperLipUp", (0.0, -0.48), (0.25, 0.03), (0.0, 1.0, 0.0))
    both = kit.Bump("mouthStretch", (0.0, -0.57), (0.25, 0.12), (0.0, -1.0, 0.0))  # spans both lips
    rig = kit.face_rig([up, both], regions=kit.FACE_REGIONS)
    assert packing.find_symmetry_pairs(rig, shape=False) == []


def test_regions_from_a_json_file(tmp_path, face):
    rig, truth = face
    path = tmp_path / "sketch.json"
    path.write_text(json.dumps({name: rig.regions[name].tolist() for name in ("upper_lip", "lower_lip")}))
    bare = dataclasses.replace(rig, regions={})
    assert packing.find_symmetry_pairs(bare, shape=False) == []  # default pairs skipped: no regions
    pairs = packing.find_symmetry_pairs(
        bare, shape=False, regions=path, region_pairs=[("upper_lip", "lower_lip")]
    )
    assert _as_sets(pairs) == _as_sets(truth["motion_pairs"])


def test_a_regions_file_with_some_default_pairs_uses_those(tmp_path, face):
    rig, truth = face
    path = tmp_path / "lips.json"
    path.write_text(json.dumps({name: rig.regions[name].tolist() for name in ("upper_lip", "lower_lip")}))
    bare = dataclasses.replace(rig, regions={})
    analysis = packing.analyse(bare, bare.neutral, regions=path)
    assert _as_sets(analysis.pairs) >= _as_sets(truth["motion_pairs"])
    assert any("skipped region pairs upper_eyelid_L/lower_eyelid_L" in note and str(path) in note
               for note in analysis.notes)  # fmt: skip
    unrelated = tmp_path / "unrelated.json"
    unrelated.write_text(json.dumps({"upperLip": [1, 2], "lowerLip": [3]}))
    with pytest.raises(ValueError, match="regions: lowerLip, upperLip"):
        packing.analyse(bare, bare.neutral, regions=unrelated)


def test_regions_from_the_face_groups_of_an_obj(tmp_path, face):
    rig, truth = face
    lines = [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in rig.neutral]
    for name in ("upper_lip", "lower_lip"):
        inside = np.isin(rig.triangles, rig.regions[name]).all(axis=1)
        lines.append(f"g {name}")
        lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in rig.triangles[inside]]
    path = tmp_path / "selection.obj"
    path.write_text("\n".join(lines) + "\n")
    bare = dataclasses.replace(rig, regions={})
    pairs = packing.find_symmetry_pairs(bare, shape=False, regions=path)
    assert _as_sets(pairs) == _as_sets(truth["motion_pairs"])
    other = tmp_path / "other.obj"
    other.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\ng lips\nf 1 2 3\n")
    with pytest.raises(ValueError, match="other.obj: the selection mesh has 3 vertices"):
        packing.find_symmetry_pairs(bare, regions=other)


def test_missing_default_regions_are_reported_not_fatal(face):
    rig, _ = face
    bare = dataclasses.replace(rig, regions={})
    analysis = packing.analyse(bare, bare.neutral)
    assert any("motion symmetry skipped region pairs upper_lip/lower_lip" in note for note in analysis.notes)


def test_unknown_region_names_are_named(tmp_path, face):
    rig, _ = face
    with pytest.raises(
        ValueError, match=r"no region 'upper_lips' of the region pairs; rig regions: lower_eyelid_L"
    ):
        packing.find_symmetry_pairs(rig, region_pairs=[("upper_lips", "lower_lip")])
    path = tmp_path / "sketch.json"
    path.write_text(json.dumps({"upper_lip": [1, 2]}))
    with pytest.raises(
        ValueError, match=rf"no region 'lower_lip' of the region pairs; {path} regions: upper_lip"
    ):
        packing.find_symmetry_pairs(rig, regions=path, region_pairs=[("upper_lip", "lower_lip")])


def test_bad_region_files_are_named(tmp_path, face):
    rig, _ = face
    with pytest.raises(ValueError, match="missing.json: no such file"):
        packing.find_symmetry_pairs(rig, regions=tmp_path / "missing.json")
    broken = tmp_path / "broken.json"
    broken.write_text("{")
    with pytest.raises(ValueError, match="broken.json: not a readable JSON regions file"):
        packing.find_symmetry_pairs(rig, regions=broken)
    outside = tmp_path / "outside.json"
    outside.write_text(json.dumps({"upper_lip": [0, 99999], "lower_lip": [1]}))
    with pytest.raises(ValueError, match=r"outside.json: region 'upper_lip' indexes outside 0..1680"):
        packing.find_symmetry_pairs(rig, regions=outside)


def test_unknown_parameter_is_named(face):
    rig, _ = face
    with pytest.raises(
        ValueError, match="unknown packing parameter 'motion_cosine' \\(did you mean 'motion_cos'\\?\\)"
    ):
        packing.find_symmetry_pairs(rig, motion_cosine=-0.9)


@pytest.mark.parametrize("preset", ["tiny", "arkit52", "male", "toon", "female", "digidouble"])
def test_detector_recovers_the_generated_truth(preset):
    rig = rigs.generate(preset, seed=0)
    truth = rig.truth
    expected = _as_sets(truth.mirror_pairs) | _as_sets(truth.motion_pairs)
    found = _as_sets(packing.find_symmetry_pairs(rig))
    false = found - expected
    assert not false, f"{preset}: false pairs {sorted(map(sorted, false))}"
    recovered = len(found & expected) / max(len(expected), 1)
    assert recovered >= 0.95, f"{preset}: missed {sorted(map(sorted, expected - found))}"
    analysis = packing.analyse(rig, rig.neutral)
    assert set(truth.self_symmetric) <= set(analysis.self_symmetric) | set(analysis.empty_names)


def _with_static_part(rig, share: float):
    """``rig`` with a one-sided part no blendshape moves (hair, a prop), of ``share`` of its vertices, off
    the right of the face."""
    from dataclasses import replace

    neutral = rig.neutral
    low, high = neutral.min(axis=0), neutral.max(axis=0)
    n_extra = int(share * rig.n_vertices) // 3 * 3
    centre = [high[0] + 0.3 * (high[0] - low[0]), neutral[:, 1].mean(), neutral[:, 2].mean()]
    extra = centre + np.random.default_rng(3).normal(0, 0.05 * (high - low).max(), (n_extra, 3))
    deltas = np.zeros((rig.n_shapes, rig.n_vertices + n_extra, 3), dtype=rig.deltas.dtype)
    deltas[:, : rig.n_vertices] = rig.deltas
    triangles = np.vstack([rig.triangles, rig.n_vertices + np.arange(n_extra).reshape(-1, 3)])
    return replace(rig, neutral=np.vstack([neutral, extra]), deltas=deltas, triangles=triangles)


@pytest.mark.filterwarnings("ignore::packing.MissingTargetWarning")
def test_a_one_sided_static_part_does_not_break_the_mirror_pairs(monkeypatch):
    """A part no shape moves and without a mirror image pulls the plane fitted on the whole mesh off the
    face; the plane fitted on the moved vertices gives the pairs of the rig without that part."""
    import packing._symmetry as symmetry

    rig = rigs.generate("tiny")
    lumpy = _with_static_part(rig, 0.5)
    analysis = packing.analyse(lumpy)
    assert analysis.pairs == packing.analyse(rig).pairs
    assert any("symmetry plane fitted on the" in note for note in analysis.notes)
    monkeypatch.setattr(symmetry, "MIRROR_RETRY_SHARE", 1.0)  # the whole mesh's plane alone
    assert len(packing.analyse(lumpy).pairs) < len(analysis.pairs)
