"""Hostile-input corpus (`tests/rigs/test_hostile_inputs.py`): GLB containers."""

from __future__ import annotations

import json
import struct
from collections.abc import Callable
from pathlib import Path

from tests.rigs.hostile_corpus import add, case
from tests.rigs.hostile_gltf import gltf_document


def glb_bytes(document: dict, blob: bytes, *, bin_chunk: bool = True) -> bytes:
    document = json.loads(json.dumps(document))
    document["buffers"][0].pop("uri", None)
    text = json.dumps(document).encode()
    text += b" " * (-len(text) % 4)
    chunks = struct.pack("<I4s", len(text), b"JSON") + text
    if bin_chunk:
        padded = blob + b"\0" * (-len(blob) % 4)
        chunks += struct.pack("<I4s", len(padded), b"BIN\x00") + padded
    return struct.pack("<4sII", b"glTF", 2, 12 + len(chunks)) + chunks


def glb_case(name: str, change: Callable[[bytes], bytes], error: str) -> None:
    def build(folder: Path) -> tuple[Path, dict]:
        path = folder / "face.glb"
        path.write_bytes(change(glb_bytes(*gltf_document())))
        return path, {}

    add(f"glb/{name}", build, error)


def at(offset: int, value: bytes) -> Callable[[bytes], bytes]:
    return lambda data: data[:offset] + value + data[offset + len(value) :]


def json_chunk_length(data: bytes) -> int:
    return struct.unpack_from("<I", data, 12)[0]


glb_case(
    "truncated-header", lambda data: data[:8], r"face\.glb: truncated GLB header \(8 bytes\)|not a readable"
)
glb_case(
    "length-too-long", at(8, struct.pack("<I", 10**6)), r"GLB header says 1000000 bytes, the file has \d+"
)
glb_case("length-too-short", at(8, struct.pack("<I", 40)), r"GLB header says 40 bytes")
glb_case("trailing-garbage", lambda data: data + b"garbage!", r"GLB header says \d+ bytes, the file has \d+")
glb_case("version-1", at(4, struct.pack("<I", 1)), r"GLB container version 1, expected 2")
glb_case("first-chunk-bin", at(16, b"BIN\x00"), r"the first GLB chunk is not JSON")
glb_case(
    "chunk-past-end", at(12, struct.pack("<I", 10**7)), r"GLB chunk 0 of 10000000 bytes runs past the end"
)
glb_case(
    "two-json-chunks",
    lambda data: (
        struct.pack("<4sII", b"glTF", 2, len(data) + 12)
        + data[12:]
        + struct.pack("<I4s", 4, b"JSON")
        + b"{}  "
    ),
    r"holds one JSON chunk and at most one BIN chunk",
)
glb_case(
    "two-bin-chunks",
    lambda data: (
        struct.pack("<4sII", b"glTF", 2, len(data) + 12)
        + data[12:]
        + struct.pack("<I4s", 4, b"BIN\x00")
        + b"\0" * 4
    ),
    r"holds one JSON chunk and at most one BIN chunk",
)
glb_case(
    "json-garbage",
    lambda data: data[:20] + b"#" * json_chunk_length(data) + data[20 + json_chunk_length(data) :],
    r"not a readable glTF 2\.0 file \(JSONDecodeError",
)
glb_case(
    "json-not-utf8",
    lambda data: data[:20] + b"\xff" * json_chunk_length(data) + data[20 + json_chunk_length(data) :],
    r"not a readable glTF 2\.0 file",
)
glb_case(
    "bin-cut",
    lambda data: (
        struct.pack("<4sII", b"glTF", 2, len(data) - 100)
        + data[12 : 20 + json_chunk_length(data)]
        + struct.pack("<I4s", 164, b"BIN\x00")
        + data[-164:]
    ),
    r"buffer 0 holds 164 bytes, fewer than its byteLength 264",
)
glb_case(
    "bin-missing",
    lambda data: (
        struct.pack("<4sII", b"glTF", 2, 20 + json_chunk_length(data))
        + data[12 : 20 + json_chunk_length(data)]
    ),
    r"buffer 0 has no URI and the file has no GLB binary chunk",
)
glb_case(
    "chunk-header-cut",
    lambda data: struct.pack("<4sII", b"glTF", 2, len(data) + 4) + data[12:] + b"\0\0\0\0",
    r"GLB chunk 2 has a truncated header",
)
glb_case("empty-file", lambda data: b"", r"face\.glb: not a readable glTF 2\.0 file")
glb_case("magic-only", lambda data: b"glTF", r"face\.glb: truncated GLB header \(4 bytes\)")
glb_case(
    "unknown-chunk-then-bad-count",
    lambda data: (
        struct.pack("<4sII", b"glTF", 2, len(data) + 12)
        + data[12:].replace(b'"count": 6', b'"count": 7', 1)
        + struct.pack("<I4s", 4, b"XTRA")
        + b"\0" * 4
    ),
    r"face\.glb: mesh 'Face' primitive 0 POSITION: reads past the end of bufferView 0",
)


@case(
    "glb/buffer-1-without-uri", r"face\.glb: buffer 1 has no URI; only buffer 0 may be the GLB binary chunk"
)
def _second_glb_buffer(folder: Path) -> tuple[Path, dict]:
    document, blob = gltf_document()
    data = glb_bytes(document, blob)
    document["buffers"].append({"byteLength": 8})
    document["bufferViews"][1]["buffer"] = 1
    path = folder / "face.glb"
    path.write_bytes(glb_bytes(document, blob))
    assert data != path.read_bytes()
    return path, {}
