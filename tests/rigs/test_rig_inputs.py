"""`rigs.load_with_inputs`: a rig's content is everything its read opened, in every form a rig takes.

For each form, changing any file the read opened, or adding a shape where the reader looks for shapes,
changes the digest and is named by `RigInputs.changes`; a file the read never opened does not.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

import rigs
from tests.rigs.hostile_gltf import gltf_document
from tests.rigs.test_io_target import write_set


def _tiny() -> rigs.Rig:
    neutral = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]])
    deltas = np.zeros((2, 4, 3))
    deltas[0, 0, 2], deltas[1, 3, 2] = 0.5, 0.25
    return rigs.Rig(neutral, deltas, np.array([[0, 1, 2], [1, 3, 2]]), ["lift", "rest"])


def touch(path: Path) -> None:
    """Change a file's bytes so that it still reads: a text file gains a blank line, a binary buffer's
    first byte flips (a glTF reads only the bytes its buffer declares)."""
    data = path.read_bytes()
    path.write_bytes(bytes([data[0] ^ 1]) + data[1:] if path.suffix == ".bin" else data + b"\n")


def _plain_obj_folder(folder: Path) -> list[Path]:
    """A folder of OBJ files as a modelling tool exports them: a neutral and one file per shape."""
    rigs.save(_tiny(), folder, format="obj-folder")
    (folder / "rig.json").unlink()
    return sorted(folder.glob("*.obj"))


def _obj_neutral(folder: Path) -> tuple[Path, list[Path]]:
    return folder / "neutral.obj", _plain_obj_folder(folder)


def _obj_folder(folder: Path) -> tuple[Path, list[Path]]:
    return folder, _plain_obj_folder(folder)


def _obj_manifest(folder: Path) -> tuple[Path, list[Path]]:
    rigs.save(_tiny(), folder, format="obj-folder")
    manifest = folder / "rig.json"
    manifest.write_text(json.dumps({"neutral": "neutral.obj", "shapes": ["lift", "rest"]}))
    return manifest, [manifest, *sorted(folder.glob("*.obj"))]


def _gltf_percent_uri(folder: Path) -> tuple[Path, list[Path]]:
    folder.mkdir()
    document, blob = gltf_document()
    document["buffers"][0]["uri"] = "face%20data.bin"
    (folder / "face data.bin").write_bytes(blob)
    path = folder / "face.gltf"
    path.write_text(json.dumps(document))
    return path, [path, folder / "face data.bin"]


def _target_manifest(folder: Path) -> tuple[Path, list[Path]]:
    write_set(folder)
    manifest = folder / "set.json"
    manifest.write_text(json.dumps({"base": "base.obj", "targets": "targets/*.target"}))
    return manifest, [manifest, folder / "base.obj", *sorted((folder / "targets").glob("*.target"))]


def _npz(folder: Path) -> tuple[Path, list[Path]]:
    folder.mkdir()
    path = rigs.save(_tiny(), folder / "face.npz")
    return path, [path]


def _usd_with_sublayer_and_clip(folder: Path) -> tuple[Path, list[Path]]:
    """``face.usda``, which sublayers ``base.usda`` (the rig) and gives the face mesh a value clip
    ``clip.usda``: the argument and the files it composes (skipped without the usd extra)."""
    pytest.importorskip("pxr", reason="usd-core is not installed (the usd extra)")
    from pxr import Sdf, Usd

    folder.mkdir()
    rigs.save(_tiny(), folder / "base.usda")
    (folder / "clip.usda").write_bytes((folder / "base.usda").read_bytes())
    path = folder / "face.usda"
    layer = Sdf.Layer.CreateNew(str(path))
    layer.subLayerPaths.append("./base.usda")
    stage = Usd.Stage.Open(layer)
    face = next(prim for prim in stage.Traverse() if prim.GetTypeName() == "Mesh")
    clips = Usd.ClipsAPI(stage.OverridePrim(face.GetPath()))
    clips.SetClipPrimPath(str(face.GetPath()))
    clips.SetClipAssetPaths([Sdf.AssetPath("./clip.usda")])
    clips.SetClipActive([(0, 0)])
    layer.Save()
    return path, [path, folder / "base.usda", folder / "clip.usda"]


FORMS: dict[str, Callable[[Path], tuple[Path, list[Path]]]] = {
    "neutral-obj": _obj_neutral,
    "obj-folder": _obj_folder,
    "rig-json": _obj_manifest,
    "gltf-percent-uri": _gltf_percent_uri,
    "target-set-json": _target_manifest,
    "npz": _npz,
    "usd-sublayer-clip": _usd_with_sublayer_and_clip,
}


@pytest.mark.parametrize("form", sorted(FORMS))
def test_every_file_a_read_opens_is_in_the_digest(form: str, tmp_path: Path) -> None:
    argument, files = FORMS[form](tmp_path / "rig")
    _, inputs = rigs.load_with_inputs(argument)
    assert sorted(inputs.files) == sorted(inputs.relative(path) for path in files)
    (tmp_path / "rig" / "notes.txt").write_text("not part of the rig")
    assert rigs.load_with_inputs(argument)[1].digest == inputs.digest
    for path in files:
        saved = tmp_path / "saved"
        shutil.copy(path, saved)
        touch(path)
        _, later = rigs.load_with_inputs(argument)
        assert later.digest != inputs.digest, path
        assert inputs.changes(later) == [f"{inputs.relative(path)} changed"]
        shutil.copy(saved, path)
    assert rigs.load_with_inputs(argument)[1].digest == inputs.digest


@pytest.mark.parametrize("form", ["neutral-obj", "obj-folder"])
def test_a_shape_added_beside_the_others_changes_the_rig(form: str, tmp_path: Path) -> None:
    argument, _ = FORMS[form](tmp_path / "rig")
    _, inputs = rigs.load_with_inputs(argument)
    shutil.copy(tmp_path / "rig" / "lift.obj", tmp_path / "rig" / "lift2.obj")
    _, later = rigs.load_with_inputs(argument)
    assert later.digest != inputs.digest
    assert "lift2.obj is new" in inputs.changes(later)
    assert any(change.startswith("the entries of . changed (+ lift2.obj") for change in inputs.changes(later))


def test_bytes_a_read_never_reaches_are_not_the_rig(tmp_path: Path) -> None:
    argument, _ = _gltf_percent_uri(tmp_path / "rig")
    _, inputs = rigs.load_with_inputs(argument)
    buffer = tmp_path / "rig" / "face data.bin"
    buffer.write_bytes(buffer.read_bytes() + b"trailing bytes past the buffer's byteLength")
    assert rigs.load_with_inputs(argument)[1].digest == inputs.digest


def test_inputs_round_trip_through_json(tmp_path: Path) -> None:
    argument, _ = _target_manifest(tmp_path / "rig")
    _, inputs = rigs.load_with_inputs(argument)
    again = rigs.RigInputs.from_document(inputs.root, json.loads(json.dumps(inputs.document())))
    assert again.digest == inputs.digest and inputs.changes(again) == []


def test_reads_outside_a_recording_are_not_collected(tmp_path: Path) -> None:
    argument, _ = _npz(tmp_path / "rig")
    with rigs._inputs.recording(tmp_path) as outer:
        pass
    rigs.load(argument)
    assert outer.files == {} and outer.listings == {}
