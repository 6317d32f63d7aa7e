"""The `rigs.load` / `rigs.save` front door: format detection, options, units and the load report."""

from __future__ import annotations

import json
from dataclasses import asdict

import numpy as np
import pytest

import rigs
from rigs import Rig, RigError

NEUTRAL = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]])
TRIANGLES = np.array([[0, 1, 2], [1, 3, 2]])


def tiny_rig() -> Rig:
    deltas = np.zeros((2, 4, 3))
    deltas[0, 3] = [0, 0, 0.2]
    return Rig(
        neutral=NEUTRAL,
        deltas=deltas,
        triangles=TRIANGLES,
        names=("lift", "rest"),
        provenance=rigs.Provenance(units="cm"),
    )


def test_detects_every_format(tmp_path):
    npz = rigs.save(tiny_rig(), tmp_path / "a.npz")
    folder = rigs.save(tiny_rig(), tmp_path / "objs")
    targets = tmp_path / "targets"
    targets.mkdir()
    (targets / "base.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    (targets / "t.target").write_text("0 0 0 1\n")
    manifest = tmp_path / "set.json"
    manifest.write_text(json.dumps({"base": "targets/base.obj", "targets": ["targets/t.target"]}))
    (tmp_path / "x.glb").write_bytes(b"")
    (tmp_path / "x.zip").write_bytes(b"")
    assert rigs.detect_format(npz).name == "npz"
    assert rigs.detect_format(folder).name == "obj-folder"
    assert rigs.detect_format(folder / "rig.json").name == "obj-folder"
    assert rigs.detect_format(targets).name == "target"
    assert rigs.detect_format(manifest).name == "target"
    assert rigs.detect_format(tmp_path / "x.glb").name == "gltf"
    assert rigs.detect_format(tmp_path / "x.zip").name == "target"
    assert rigs.load(manifest).names == ("t",)


def test_unknown_suffix_empty_folder_and_unknown_option(tmp_path):
    (tmp_path / "rig.fbx").write_bytes(b"")
    with pytest.raises(RigError, match=r"rig\.fbx: unknown rig format '\.fbx'"):
        rigs.load(tmp_path / "rig.fbx")
    (tmp_path / "empty").mkdir()
    known = r"\(npz, gltf, usd, target, obj-folder\)"
    with pytest.raises(RigError, match=rf"empty: folder holds no rig of a known format {known}"):
        rigs.load(tmp_path / "empty")
    path = rigs.save(tiny_rig(), tmp_path / "a.npz")
    with pytest.raises(RigError, match=r"a\.npz: unknown option 'weld' for npz \(accepted: none\)"):
        rigs.load(path, weld=True)
    with pytest.raises(RigError, match=r"a\.npz: unknown format 'fbx'"):
        rigs.load(path, format="fbx")
    with pytest.raises(RigError, match=r"a\.npz: noise_floor must be >= 0, got -1"):
        rigs.load(path, noise_floor=-1)


def test_units_override_and_report(tmp_path):
    rig = rigs.load(rigs.save(tiny_rig(), tmp_path / "a.npz"), units="mm")
    assert rig.provenance.units == "mm"
    assert rig.load_report.empty_shapes == ("rest",)
    assert rig.load_report.degenerate_triangles == 0
    assert asdict(rig.load_report.noise) == {
        "relative_floor": 0.0,
        "floor": 0.0,
        "rounding_step": 0.0,
        "zeroed": {},
    }


def test_save_chooses_by_suffix_or_format(tmp_path):
    assert (rigs.save(tiny_rig(), tmp_path / "plain") / "neutral.obj").is_file()
    assert rigs.save(tiny_rig(), tmp_path / "forced.rig", format="npz").is_file()
    assert rigs.load(tmp_path / "forced.rig", format="npz").names == ("lift", "rest")
    with pytest.raises(RigError, match=r"x\.glb: cannot save as '\.glb'"):
        rigs.save(tiny_rig(), tmp_path / "x.glb")
    with pytest.raises(RigError, match=r"x: cannot save format 'gltf': it is read only"):
        rigs.save(tiny_rig(), tmp_path / "x", format="gltf")


def test_obj_folder_and_npz_agree(tmp_path):
    rig = tiny_rig()
    from_npz = rigs.load(rigs.save(rig, tmp_path / "a.npz"))
    from_objs = rigs.load(rigs.save(rig, tmp_path / "objs"))
    np.testing.assert_allclose(from_objs.deltas, from_npz.deltas, atol=1e-15)
    assert from_objs.names == from_npz.names and from_objs.provenance.units == "cm"
