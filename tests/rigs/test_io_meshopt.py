"""meshopt-compressed glTF (``EXT_meshopt_compression``): decoded with a decoder package, checked against the
uncompressed export it was made from; refused with a working hint without one."""

from __future__ import annotations

import json
import struct
import sys

import numpy as np
import pytest

import rigs
from rigs import RigError
from rigs._gltf_write import glb_bytes

pytest.importorskip("pygltflib")


def split_glb(data: bytes) -> tuple[dict, bytes]:
    (json_length,) = struct.unpack_from("<I", data, 12)
    document = json.loads(data[20 : 20 + json_length])
    (bin_length,) = struct.unpack_from("<I", data, 20 + json_length)
    return document, data[28 + json_length : 28 + json_length + bin_length]


def join_glb(document: dict, blob: bytes) -> bytes:
    text = json.dumps(document).encode()
    text += b" " * (-len(text) % 4)
    blob += b"\0" * (-len(blob) % 4)
    length = 12 + 8 + len(text) + 8 + len(blob)
    return (
        struct.pack("<4sII", b"glTF", 2, length)
        + struct.pack("<I4s", len(text), b"JSON")
        + text
        + struct.pack("<I4s", len(blob), b"BIN\0")
        + blob
    )


def compress(data: bytes) -> bytes:
    """The GLB with every buffer view meshopt-compressed (as gltfpack -c writes it: a fallback buffer
    without data, the compressed bytes in the GLB chunk)."""
    import almeshopt

    document, blob = split_glb(data)
    packed = bytearray()
    n_vertices = document["accessors"][0]["count"]
    for view, accessor in zip(document["bufferViews"], document["accessors"], strict=True):
        raw = blob[view["byteOffset"] : view["byteOffset"] + view["byteLength"]]
        if view.get("target") == 34963:  # indices
            indices = np.frombuffer(raw, dtype=np.uint32)
            encoded, mode, stride = almeshopt.encode_index_buffer(indices.copy(), n_vertices), "TRIANGLES", 4
        else:
            values = np.frombuffer(raw, dtype=np.uint8).reshape(accessor["count"], 12).copy()
            encoded, mode, stride = almeshopt.encode_vertex_buffer(values, version=0), "ATTRIBUTES", 12
        extension = {
            "buffer": 0,
            "byteOffset": len(packed),
            "byteLength": len(encoded),
            "byteStride": stride,
            "count": accessor["count"],
            "mode": mode,
        }
        packed += encoded + b"\0" * (-len(encoded) % 4)
        view.update(
            buffer=1, byteOffset=view["byteOffset"], extensions={"EXT_meshopt_compression": extension}
        )
    document["buffers"] = [
        {"byteLength": len(packed)},
        {"byteLength": len(blob), "extensions": {"EXT_meshopt_compression": {"fallback": True}}},
    ]
    document["extensionsUsed"] = document["extensionsRequired"] = ["EXT_meshopt_compression"]
    return join_glb(document, bytes(packed))


@pytest.fixture
def exports(tmp_path):
    pytest.importorskip("almeshopt")
    tiny = rigs.generate("tiny")
    plain = tmp_path / "plain.glb"
    plain.write_bytes(glb_bytes(tiny))
    packed = tmp_path / "packed.glb"
    packed.write_bytes(compress(plain.read_bytes()))
    return plain, packed


def test_meshopt_compressed_glb_decodes_to_the_uncompressed_export(exports):
    plain, packed = exports
    assert packed.stat().st_size < plain.stat().st_size
    expected, decoded = rigs.load(plain), rigs.load(packed)
    assert decoded.names == expected.names
    assert np.array_equal(decoded.neutral, expected.neutral) and np.array_equal(
        decoded.deltas, expected.deltas
    )
    assert np.array_equal(rotated(decoded.triangles), rotated(expected.triangles))  # the codec may rotate


def rotated(triangles: np.ndarray) -> np.ndarray:
    """Each triangle turned to start at its smallest corner (same orientation)."""
    first = np.argmin(triangles, axis=1)
    return np.stack([np.roll(row, -shift) for row, shift in zip(triangles, first, strict=True)])


def test_without_a_decoder_the_hint_names_a_command_that_works(exports, monkeypatch):
    monkeypatch.setitem(sys.modules, "almeshopt", None)
    with pytest.raises(
        RigError,
        match=r"packed\.glb: compressed with EXT_meshopt_compression .*"
        r"`gltfpack -i in\.glb -o out\.glb -noq`",
    ):
        rigs.load(exports[1])


def test_corrupt_compressed_data_is_one_line_error(exports, tmp_path):
    document, blob = split_glb(exports[1].read_bytes())
    broken = tmp_path / "broken.glb"
    broken.write_bytes(join_glb(document, b"\xff" * len(blob)))
    with pytest.raises(
        RigError, match=r"broken\.glb: .*EXT_meshopt_compression: the compressed data does not decode"
    ):
        rigs.load(broken)
    document["bufferViews"][0]["extensions"]["EXT_meshopt_compression"]["filter"] = "OCTAHEDRAL"
    broken.write_bytes(join_glb(document, blob))
    with pytest.raises(RigError, match=r"filter 'OCTAHEDRAL' is not decoded here; .*gltfpack"):
        rigs.load(broken)
