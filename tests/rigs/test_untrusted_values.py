"""Values that are not what they claim: a glTF data URI longer than its buffer, a rotation that is no unit
quaternion, a region given as a 2-D array, a shape whose file name is not UTF-8: each is refused with one
line naming the file, never taken as something else."""

from __future__ import annotations

import base64
import json
import os
from pathlib import Path

import numpy as np
import pytest

import rigs
from rigs import RigError


def _gltf(folder: Path, *, extra_bytes: int = 0, rotation: list[float] | None = None) -> Path:
    """A one-triangle glTF with one morph target, its buffer a data URI (``extra_bytes`` more than its
    byteLength says), its node rotated by ``rotation``."""
    neutral = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype=np.float32)
    delta = np.array([[0, 0, 0.1], [0, 0, 0], [0, 0, 0]], dtype=np.float32)
    indices = np.array([0, 1, 2], dtype=np.uint32)
    blob = neutral.tobytes() + delta.tobytes() + indices.tobytes()
    views = [
        {"buffer": 0, "byteOffset": 0, "byteLength": 36},
        {"buffer": 0, "byteOffset": 36, "byteLength": 36},
        {"buffer": 0, "byteOffset": 72, "byteLength": 12},
    ]
    node: dict = {"mesh": 0}
    if rotation is not None:
        node["rotation"] = rotation
    document = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [node],
        "meshes": [
            {
                "primitives": [{"attributes": {"POSITION": 0}, "indices": 2, "targets": [{"POSITION": 1}]}],
                "extras": {"targetNames": ["jawOpen"]},
            }
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"},
            {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5125, "count": 3, "type": "SCALAR"},
        ],
        "bufferViews": views,
        "buffers": [
            {
                "byteLength": len(blob),
                "uri": "data:application/octet-stream;base64,"
                + base64.b64encode(blob + b"\0" * extra_bytes).decode(),
            }
        ],
    }
    path = folder / "face.gltf"
    path.write_text(json.dumps(document))
    return path


def test_a_data_uri_longer_than_its_byte_length_is_refused_before_it_is_decoded(tmp_path) -> None:
    assert rigs.load(_gltf(tmp_path, extra_bytes=2)).n_shapes == 1  # (padding to four bytes is allowed)
    with pytest.raises(RigError, match=r"face.gltf: buffer 0: its data URI holds about \d+ bytes, more than"):
        rigs.load(_gltf(tmp_path, extra_bytes=10_000))


@pytest.mark.parametrize("rotation", [[0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 2.0], [0.5, 0.5, 0.5, 0.0]])
def test_a_rotation_that_is_no_unit_quaternion_is_refused(tmp_path, rotation) -> None:
    with pytest.raises(RigError, match=r"face.gltf: node 0 rotation .* is not a unit quaternion"):
        rigs.load(_gltf(tmp_path, rotation=rotation))
    turned = rigs.load(_gltf(tmp_path, rotation=[0.0, 0.0, float(np.sin(0.5)), float(np.cos(0.5))]))
    assert turned.n_shapes == 1


def test_a_region_array_of_two_dimensions_is_refused_not_flattened() -> None:
    rig = rigs.generate("tiny")
    with pytest.raises(RigError, match=r"region 'lip' must be a flat list of vertex indices, got .*\(2, 2\)"):
        rigs.Rig(
            rig.neutral, rig.deltas, rig.triangles, rig.names, regions={"lip": np.array([[1, 2], [3, 4]])}
        )
    with pytest.raises(RigError, match=r"regions.json: region 'lip' must be a list of vertex indices"):
        rigs.regions_from_mapping({"lip": [[1, 2], [3, 4]]}, rig.n_vertices, "regions.json")


def test_a_shape_file_named_with_bytes_that_are_not_utf8_is_refused(tmp_path) -> None:
    folder = rigs.save(rigs.generate("tiny"), tmp_path / "rig")
    (folder / "rig.json").unlink()
    os.rename(folder / "jawOpen.obj", os.fsencode(folder) + b"/jaw\xff\xfeOpen.obj")
    with pytest.raises(RigError, match=r"blendshape name 'jaw\\udcff\\udcfeOpen' is not text"):
        rigs.load(folder)
