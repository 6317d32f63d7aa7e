"""Untrusted USD rigs: value clips, payloads and variant-set references are held to the rig's folder, and
what ``pxr`` cannot read is one line naming the file."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

import rigs
from rigs import RigError

pytest.importorskip("pxr", reason="usd-core is not installed (pip install 'expression-packing-harness[usd]')")

from pxr import Sdf, Usd  # noqa: E402 - after the skip


@pytest.fixture
def folder(tmp_path) -> Path:
    """A rig folder holding ``base.usda`` (the tiny rig), beside ``outside.usda`` (a rig outside it)."""
    rig = rigs.generate("tiny")
    rigs.save(rig, tmp_path / "outside.usda")
    inside = tmp_path / "rig"
    rigs.save(rig, inside / "base.usda")
    return inside


def _with_clips(folder: Path, name: str, **clips: object) -> Path:
    """``base.usda`` with value clips on the face mesh (``Usd.ClipsAPI`` setters by keyword), as ``name``."""
    layer = Sdf.Layer.FindOrOpen(str(folder / "base.usda"))
    stage = Usd.Stage.Open(layer)
    api = Usd.ClipsAPI(stage.GetPrimAtPath("/Rig/Face"))
    api.SetClipPrimPath("/Rig/Face")
    for setter, value in clips.items():
        getattr(api, setter)(value)
    path = folder / name
    layer.Export(str(path))
    layer.Reload(force=True)
    return path


def _with_arc(folder: Path, name: str, arc: str, asset: str) -> Path:
    """A stage ``name`` whose ``/Rig`` references (in a variant set) or payloads ``asset``."""
    path = folder / name
    stage = Usd.Stage.CreateNew(str(path))
    prim = stage.DefinePrim("/Rig")
    if arc == "payload":
        prim.GetPayloads().AddPayload(asset)
    else:
        variants = prim.GetVariantSets().AddVariantSet("look")
        variants.AddVariant("a")
        variants.SetVariantSelection("a")
        with variants.GetVariantEditContext():
            prim.GetReferences().AddReference(asset)
    stage.GetRootLayer().Save()
    return path


def _assert_one_line(error: pytest.ExceptionInfo, *fragments: str) -> None:
    message = str(error.value)
    assert "\n" not in message and "Error in" not in message and ".cpp" not in message, message
    for fragment in fragments:
        assert fragment in message, message


@pytest.mark.parametrize("where", ["../outside.usda", "absolute"])
def test_clip_asset_paths_outside_the_folder_are_refused(folder, where) -> None:
    asset = str(folder.parent / "outside.usda") if where == "absolute" else where
    path = _with_clips(folder, "clips.usda", SetClipAssetPaths=[Sdf.AssetPath(asset)], SetClipActive=[(0, 0)])
    with pytest.raises(RigError) as error:
        rigs.load(path)
    _assert_one_line(error, str(path), asset)


def test_a_clip_manifest_outside_the_folder_is_refused(folder) -> None:
    shutil.copy(folder / "base.usda", folder / "clip.usda")
    path = _with_clips(
        folder,
        "clips.usda",
        SetClipAssetPaths=[Sdf.AssetPath("./clip.usda")],
        SetClipActive=[(0, 0)],
        SetClipManifestAssetPath=Sdf.AssetPath("../outside.usda"),
    )
    with pytest.raises(RigError, match=r"\.\./outside\.usda.*leaves the folder"):
        rigs.load(path)


def test_a_clip_template_outside_the_folder_is_refused(folder) -> None:
    (folder.parent / "clip.1.usda").write_bytes((folder / "base.usda").read_bytes())
    path = _with_clips(
        folder,
        "template.usda",
        SetClipTemplateAssetPath="../clip.#.usda",
        SetClipTemplateStartTime=1,
        SetClipTemplateEndTime=1,
        SetClipTemplateStride=1,
    )
    with pytest.raises(RigError, match=r"\.\./clip\.1\.usda.*leaves the folder"):
        rigs.load(path)


def test_the_files_of_a_clip_template_inside_the_folder_are_checked_too(folder) -> None:
    (folder / "clips").mkdir()
    clip = folder / "clips" / "clip.001.usda"
    clip.symlink_to(folder.parent / "outside.usda")
    path = _with_clips(
        folder,
        "template.usda",
        SetClipTemplateAssetPath="./clips/clip.###.usda",
        SetClipTemplateStartTime=1,
        SetClipTemplateEndTime=1,
        SetClipTemplateStride=1,
    )
    with pytest.raises(RigError, match="clip.001.usda"):
        rigs.load(path)
    clip.unlink()
    shutil.copy(folder / "base.usda", clip)
    assert rigs.load(path).names == rigs.load(folder / "base.usda").names


def test_a_clip_inside_the_folder_loads(folder) -> None:
    shutil.copy(folder / "base.usda", folder / "clip.usda")
    path = _with_clips(
        folder, "clips.usda", SetClipAssetPaths=[Sdf.AssetPath("./clip.usda")], SetClipActive=[(0, 0)]
    )
    loaded, base = rigs.load(path), rigs.load(folder / "base.usda")
    assert loaded.names == base.names and np.array_equal(loaded.deltas, base.deltas)


@pytest.mark.parametrize("arc", ["payload", "variant reference"])
@pytest.mark.parametrize("where", ["../outside.usda", "absolute"])
def test_payloads_and_variant_set_references_outside_the_folder_are_refused(folder, arc, where) -> None:
    asset = str(folder.parent / "outside.usda") if where == "absolute" else where
    path = _with_arc(folder, "arc.usda", arc, asset)
    with pytest.raises(RigError) as error:
        rigs.load(path)
    _assert_one_line(error, str(path), asset)


def test_garbage_text_is_one_line_naming_the_file(tmp_path) -> None:
    path = tmp_path / "rig.usda"
    path.write_text("#usda 1.0\n(((( this is not a layer\n")
    with pytest.raises(RigError) as error:
        rigs.load(path)
    _assert_one_line(error, str(path), "not a readable USD file")


def test_a_truncated_usdc_is_one_line_naming_the_file(tmp_path) -> None:
    whole = rigs.save(rigs.generate("tiny"), tmp_path / "whole.usdc").read_bytes()
    for size in (len(whole) // 2, 100):
        path = tmp_path / f"cut{size}.usdc"
        path.write_bytes(whole[:size])
        with pytest.raises(RigError) as error:
            rigs.load(path)
        _assert_one_line(error, str(path))


def test_a_malformed_clip_is_one_line_naming_the_clip(folder) -> None:
    clip = folder / "clip.usda"
    path = _with_clips(
        folder, "clips.usda", SetClipAssetPaths=[Sdf.AssetPath("./clip.usda")], SetClipActive=[(0, 0)]
    )
    clip.write_text("#usda 1.0\n(((( a broken clip\n")
    with pytest.raises(RigError) as error:
        rigs.load(path)
    _assert_one_line(error, str(clip), "not a readable USD file")
