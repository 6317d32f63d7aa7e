"""MakeHuman/MPFB .target sets over a base OBJ: folder, zip and JSON forms, cropping, and bad inputs."""

from __future__ import annotations

import gzip
import json
import zipfile

import numpy as np
import pytest

import rigs
from rigs import RigError
from rigs._target import crop, load_target_zip

# A 6 x 6 grid of quads (7 x 7 vertices) in two groups, plus a separate triangle ("tooth", vertices 49-51).
SIDE = 7
GRID = np.array([[x, y, 0.0] for y in range(SIDE) for x in range(SIDE)], dtype=float)
QUADS = [
    [y * SIDE + x, y * SIDE + x + 1, (y + 1) * SIDE + x + 1, (y + 1) * SIDE + x]
    for y in range(SIDE - 1)
    for x in range(SIDE - 1)
]
TOOTH = np.array([[10.0, 0, 0], [11, 0, 0], [10, 1, 0]])


def base_obj() -> str:
    lines = ["# base mesh", "g skin"]
    lines += [f"v {x:g} {y:g} {z:g}" for x, y, z in np.vstack([GRID, TOOTH])]
    lines += [f"vt {i / 10:g} 0" for i in range(10)]
    lines += ["f " + " ".join(f"{i + 1}/1" for i in quad) for quad in QUADS]
    lines += ["g helper-tooth", "f 50 51 52"]
    return "\n".join(lines) + "\n"


TARGETS = {
    "blink": "# eyelid\n24 0 -0.5 0\n25 0 -0.25 0.0\n",
    "tooth": "49 0 0.1 0\n",
    "empty": "# nothing moves\n\n",
}


def write_set(folder, targets=TARGETS):
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "base.obj").write_text(base_obj())
    (folder / "targets").mkdir(exist_ok=True)
    for name, text in targets.items():
        (folder / "targets" / f"{name}.target").write_text(text)
    return folder


def test_folder_gives_sparse_deltas_names_from_stems_and_reports_empty(tmp_path):
    rig = rigs.load(write_set(tmp_path / "set"))
    assert rig.names == ("blink", "empty", "tooth")
    assert rig.n_vertices == 52 and rig.n_triangles == 36 * 2 + 1
    np.testing.assert_array_equal(rig.deltas[0, 24], [0, -0.5, 0])
    np.testing.assert_array_equal(rig.deltas[0, 25], [0, -0.25, 0])
    np.testing.assert_array_equal(rig.deltas[2, 49], [0, 0.1, 0])
    assert np.count_nonzero(np.abs(rig.deltas).sum(axis=2)) == 3
    assert rig.load_report.empty_shapes == ("empty",) and rig.provenance.format == "makehuman-target"
    assert len(rig.faces) == 37


def test_crop_keeps_moved_vertices_plus_face_rings(tmp_path):
    folder = write_set(tmp_path / "set")
    full = rigs.load(folder)
    for rings in (0, 1, 2):
        rig = rigs.load(folder, crop_rings=rings)
        kept = rig.provenance.base.vertex_ids
        np.testing.assert_array_equal(rig.neutral, full.neutral[kept])
        np.testing.assert_array_equal(rig.deltas, full.deltas[:, kept])
        outside = np.setdiff1d(np.arange(full.n_vertices), kept)
        assert not full.deltas[:, outside].any()
        corners = np.concatenate(rig.faces) if rig.faces else np.zeros(0, dtype=int)
        assert corners.max(initial=-1) < rig.n_vertices
    # Vertices 24, 25 are neighbours in row 3 of the grid; 49 is a tooth corner.
    assert rigs.load(folder, crop_rings=0).provenance.base.vertex_ids.tolist() == [24, 25, 49]
    one_ring = rigs.load(folder, crop_rings=1)
    expected = sorted({x + y * SIDE for y in (2, 3, 4) for x in (2, 3, 4, 5)} | {49, 50, 51})
    assert one_ring.provenance.base.vertex_ids.tolist() == expected
    assert len(one_ring.faces) == 6 + 1


def test_crop_keeps_only_faces_fully_inside():
    faces = [np.array(q) for q in QUADS]
    moved = np.zeros(len(GRID), dtype=bool)
    moved[[0, 1]] = True
    kept, inside = crop(faces, len(GRID), moved, 0)
    assert kept.tolist() == [0, 1] and inside == []
    kept, inside = crop(faces, len(GRID), moved, 1)
    assert inside == [0, 1] and kept.tolist() == [0, 1, 2, 7, 8, 9]


def test_zip_json_and_gz_forms_give_the_same_rig(tmp_path):
    folder = write_set(tmp_path / "set")
    reference = rigs.load(folder)
    archive = tmp_path / "set.zip"
    with zipfile.ZipFile(archive, "w") as stream:
        stream.writestr("data/base.obj", base_obj())
        for name, text in TARGETS.items():
            stream.writestr(f"data/targets/{name}.target.gz", gzip.compress(text.encode()))
        stream.writestr("data/other/ignored.target", "0 1 1 1\n")
    zipped = rigs.load(archive, targets="data/targets/*")
    assert zipped.names == reference.names
    np.testing.assert_array_equal(zipped.deltas, reference.deltas)
    assert rigs.load(archive).names == ("blink", "empty", "ignored", "tooth")

    regions = load_target_zip(
        archive, targets="data/targets/*", crop_rings=1, group_regions={"helper-tooth": "tooth"}
    )
    np.testing.assert_array_equal(regions.neutral[regions.regions["tooth"]], TOOTH)

    for listed in (
        ["targets/blink.target", "targets/empty.target", "targets/tooth.target"],
        "targets/*.target",
    ):
        manifest = folder / "set.json"
        manifest.write_text(json.dumps({"base": "base.obj", "targets": listed, "units": "dm"}))
        loaded = rigs.load(manifest)
        assert loaded.names == reference.names and loaded.provenance.units == "dm"
        np.testing.assert_array_equal(loaded.deltas, reference.deltas)
    manifest.write_text(
        json.dumps({"base": "base.obj", "targets": {"eyeBlink": "targets/blink.target"}, "crop_rings": 0})
    )
    assert rigs.load(manifest).names == ("eyeBlink",) and rigs.load(manifest).n_vertices == 2


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("24 0 1\n", r"bad\.target:1: expected 'vid dx dy dz', got '24 0 1'"),
        ("# c\n24 0 1 x\n", r"bad\.target:2: expected 'vid dx dy dz', got '24 0 1 x'"),
        ("2.5 0 1 0\n", r"bad\.target:1: expected 'vid dx dy dz'"),
        ("52 0 1 0\n", r"bad\.target:1: vertex 52 is outside the base mesh's 0\.\.51"),
        ("-1 0 1 0\n", r"bad\.target:1: vertex -1 is outside the base mesh's 0\.\.51"),
        ("3 0 nan 0\n", r"bad\.target:1: vertex 3 has a non-finite displacement"),
        ("3 0 1 0\n4 0 1 0\n3 1 0 0\n", r"bad\.target:3: vertex 3 is listed twice \(also line 1\)"),
    ],
)
def test_bad_target_lines_name_file_and_line(tmp_path, text, message):
    folder = write_set(tmp_path / "set", {"ok": "1 0 0 1\n", "bad": text})
    with pytest.raises(RigError, match=message) as caught:
        rigs.load(folder)
    assert "\n" not in str(caught.value)


def test_duplicate_names_missing_base_and_missing_files(tmp_path):
    folder = write_set(tmp_path / "set")
    (folder / "more").mkdir()
    (folder / "more" / "blink.target").write_text("1 0 0 1\n")
    with pytest.raises(
        RigError,
        match=r"targets/blink\.target: duplicate blendshape name 'blink' \(also .*more/blink\.target\)",
    ):
        rigs.load(folder)

    bare = tmp_path / "bare"
    bare.mkdir()
    (bare / "a.target").write_text("1 0 0 1\n")
    with pytest.raises(
        RigError, match=r"bare: expected exactly one base \.obj beside the targets \(found: none\)"
    ):
        rigs.load(bare)
    with pytest.raises(RigError, match=r"nope\.obj: base mesh not found"):
        rigs.load(bare, base="nope.obj")

    manifest = folder / "set.json"
    manifest.write_text(json.dumps({"base": "base.obj", "targets": ["targets/gone.target"]}))
    with pytest.raises(RigError, match=r"gone\.target: target listed in set\.json is missing"):
        rigs.load(manifest)
    manifest.write_text(json.dumps({"base": "missing.obj", "targets": ["targets/blink.target"]}))
    with pytest.raises(RigError, match=r"missing\.obj: cannot read OBJ file"):
        rigs.load(manifest)

    archive = tmp_path / "two.zip"
    with zipfile.ZipFile(archive, "w") as stream:
        stream.writestr("a.obj", base_obj())
        stream.writestr("b.obj", base_obj())
        stream.writestr("t.target", "1 0 0 1\n")
    with pytest.raises(
        RigError, match=r"two\.zip: expected exactly one \.obj member \(found 2\); pass base=MEMBER"
    ):
        rigs.load(archive)
    with pytest.raises(RigError, match=r"two\.zip: no \.target members match 'x/\*'"):
        rigs.load(archive, base="a.obj", targets="x/*")


def test_negative_crop_rings_is_refused(tmp_path):
    with pytest.raises(RigError, match=r"crop_rings must be >= 0, got -1"):
        rigs.load(write_set(tmp_path / "set"), crop_rings=-1)


def test_options_of_another_form_are_refused(tmp_path):
    with pytest.raises(
        RigError, match=r"set: unknown option 'targets' for target \(accepted: base, crop_rings\)"
    ):
        rigs.load(write_set(tmp_path / "set"), targets="*.target")


@pytest.mark.parametrize("row", ["1_0 0 1 0", "\uff11 0 1 0", "3 0 1_0 0", "3 0 \u0661 0", "3 0 \u0131nf 0"])
def test_target_numbers_are_ascii_decimals_without_underscores(tmp_path, row):
    folder = write_set(tmp_path / "set", {"ok": "1 0 0 1\n", "bad": f"# c\n{row}\n"})
    with pytest.raises(RigError, match=r"bad\.target:2: expected 'vid dx dy dz' in ASCII decimal notation"):
        rigs.load(folder)
