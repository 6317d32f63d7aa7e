"""Fuzzing the rig readers with mutated valid files: byte flips, truncation, duplicated or dropped lines,
and random values in glTF fields. Whatever the mutation, loading gives a valid `Rig` (maybe with a
`RigWarning`) or a one-line `RigError`: never another exception, another kind of warning, or a hang."""

from __future__ import annotations

import json
import struct
import tempfile
import warnings
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings, strategies as st

import rigs
from rigs import RigError
from rigs._rig import RigWarning
from tests.rigs.rig_files import GRID, QUADS, hang_alarm

FUZZ = settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
SECONDS = 10

#: The grid's quads and one pentagon.
FACES = [*QUADS, [0, 1, 6, 5, 4]]


def obj_text(vertices: np.ndarray) -> str:
    lines = ["# fuzz", "o Face", "g skin"]
    lines += [f"v {x!r} {y!r} {z!r}" for x, y, z in vertices.tolist()]
    lines += ["vt 0 0", "vn 0 0 1"]
    lines += ["f " + " ".join(f"{i + 1}/1/1" for i in face) for face in FACES]
    return "\n".join(lines) + "\n"


NEUTRAL = obj_text(GRID).encode()
SMILE = obj_text(GRID + np.where(np.arange(16)[:, None] == 5, [0, 0, 0.3], 0)).encode()


def load_or_refuse(path: Path, **options) -> rigs.Rig | None:
    """The rig at ``path``, or None when it is refused with a one-line RigError; any other exception or a
    warning other than RigWarning fails."""
    with warnings.catch_warnings(record=True) as caught, hang_alarm(SECONDS):
        warnings.simplefilter("always")
        try:
            rig = rigs.load(path, **options)
        except RigError as error:
            assert "\n" not in str(error) and str(path.parent) in str(error), str(error)
            rig = None
    others = [w for w in caught if not issubclass(w.category, RigWarning)]
    assert not others, [f"{w.category.__name__}: {w.message}" for w in others]
    if rig is not None:
        assert isinstance(rig, rigs.Rig) and rig.deltas.shape == (rig.n_shapes, rig.n_vertices, 3)
        assert np.isfinite(rig.deltas).all() and np.isfinite(rig.neutral).all()
    return rig


@st.composite
def mutated(draw, data: bytes) -> bytes:
    """``data`` with a few byte flips, insertions, deletions and maybe a truncation."""
    out = bytearray(data)
    for _ in range(draw(st.integers(1, 6))):
        kind = draw(st.sampled_from(["flip", "insert", "delete", "digit", "duplicate"]))
        if not out:
            break
        at = draw(st.integers(0, len(out) - 1))
        if kind == "flip":
            out[at] ^= 1 << draw(st.integers(0, 7))
        elif kind == "insert":
            out[at:at] = draw(st.binary(min_size=1, max_size=8))
        elif kind == "delete":
            del out[at : at + draw(st.integers(1, 16))]
        elif kind == "digit":
            out[at:at] = str(draw(st.sampled_from([0, -1, 2**31, 2**63, 10**30, 1e308, -1e-300]))).encode()
        else:
            end = min(len(out), at + draw(st.integers(1, 64)))
            out[at:at] = out[at:end]
    if draw(st.booleans()):
        out = out[: draw(st.integers(0, len(out)))]
    return bytes(out)


@FUZZ
@given(neutral=mutated(NEUTRAL), shape=st.one_of(st.just(SMILE), mutated(SMILE)))
def test_mutated_obj_folders_load_or_are_refused(neutral: bytes, shape: bytes) -> None:
    with tempfile.TemporaryDirectory() as folder:
        rig = Path(folder) / "rig"
        rig.mkdir()
        (rig / "neutral.obj").write_bytes(neutral)
        (rig / "smile.obj").write_bytes(shape)
        loaded = load_or_refuse(rig)
        if loaded is not None:
            assert loaded.names == ("smile",) and loaded.n_triangles >= 1


# -- glTF ------------------------------------------------------------------------------------------------
POSITIONS = GRID[:6].astype(np.float32)
DELTA = np.zeros((6, 3), dtype=np.float32)
DELTA[2] = [0, 0.25, 0.5]
INDICES = np.array([0, 1, 5, 0, 5, 4, 1, 2, 5], dtype=np.uint16)
BLOB = POSITIONS.tobytes() + DELTA.tobytes() + INDICES.tobytes() + b"\0\0"


def document() -> dict:
    return {
        "asset": {"version": "2.0"},
        "nodes": [{"mesh": 0, "translation": [0, 0, 1]}],
        "meshes": [
            {
                "name": "Face",
                "primitives": [{"attributes": {"POSITION": 0}, "indices": 2, "targets": [{"POSITION": 1}]}],
                "extras": {"targetNames": ["jawOpen"]},
            }
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 6, "type": "VEC3"},
            {"bufferView": 1, "componentType": 5126, "count": 6, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5123, "count": 9, "type": "SCALAR"},
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 72},
            {"buffer": 0, "byteOffset": 72, "byteLength": 72},
            {"buffer": 0, "byteOffset": 144, "byteLength": 18},
        ],
        "buffers": [{"byteLength": len(BLOB), "uri": "mesh.bin"}],
    }


FIELDS = [
    ("accessors", ("bufferView", "byteOffset", "componentType", "count", "type", "normalized", "sparse")),
    ("bufferViews", ("buffer", "byteOffset", "byteLength", "byteStride")),
    ("buffers", ("byteLength", "uri")),
    ("nodes", ("mesh", "children", "matrix", "translation", "scale", "rotation", "skin")),
]
VALUES = st.one_of(
    st.integers(-3, 12),
    st.sampled_from([2**31, 2**32 - 1, 2**63, 10**12, -(2**31), 5126, 5125, 5121, 5120, 5130]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.booleans(),
    st.none(),
    st.sampled_from(["VEC3", "SCALAR", "VEC2", "", "../mesh.bin", "%2e%2e/x", "/dev/zero", "data:,x", "x"]),
    st.lists(st.integers(-2, 4), max_size=17),
    st.lists(st.floats(-1e300, 1e300), min_size=3, max_size=16),
    st.fixed_dictionaries({"count": st.integers(-1, 8)}),
)


@st.composite
def mutated_document(draw) -> dict:
    doc = document()
    for _ in range(draw(st.integers(1, 4))):
        array, keys = draw(st.sampled_from(FIELDS))
        item = draw(st.integers(0, len(doc[array]) - 1))
        doc[array][item][draw(st.sampled_from(keys))] = draw(VALUES)
    if draw(st.booleans()):
        doc["meshes"][0]["primitives"][0][draw(st.sampled_from(["indices", "mode", "targets"]))] = draw(
            VALUES
        )
    return doc


@FUZZ
@given(doc=mutated_document())
def test_gltf_with_random_field_values_loads_or_is_refused(doc: dict) -> None:
    with tempfile.TemporaryDirectory() as folder:
        root = Path(folder) / "asset"
        root.mkdir()
        (root / "mesh.bin").write_bytes(BLOB)
        path = root / "face.gltf"
        path.write_text(json.dumps(doc))
        load_or_refuse(path)


@FUZZ
@given(text=mutated(json.dumps(document()).encode()))
def test_gltf_with_mutated_json_text_loads_or_is_refused(text: bytes) -> None:
    with tempfile.TemporaryDirectory() as folder:
        (Path(folder) / "mesh.bin").write_bytes(BLOB)
        path = Path(folder) / "face.gltf"
        path.write_bytes(text)
        load_or_refuse(path)


def glb(doc: dict) -> bytes:
    doc = json.loads(json.dumps(doc))
    del doc["buffers"][0]["uri"]
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    chunks = (
        struct.pack("<I4s", len(text), b"JSON") + text + struct.pack("<I4s", len(BLOB), b"BIN\x00") + BLOB
    )
    return struct.pack("<4sII", b"glTF", 2, 12 + len(chunks)) + chunks


@FUZZ
@given(data=mutated(glb(document())))
def test_mutated_glb_files_load_or_are_refused(data: bytes) -> None:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "face.glb"
        path.write_bytes(data)
        loaded = load_or_refuse(path)
        if loaded is not None:
            assert loaded.n_vertices <= 6 and loaded.n_shapes <= 1


# -- .npz and .target ------------------------------------------------------------------------------------
def npz_bytes(compressed: bool) -> bytes:
    rig = rigs.Rig(
        neutral=GRID, deltas=np.zeros((1, 16, 3)), triangles=[[0, 1, 5], [0, 5, 4]], names=("lift",)
    )
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "rig.npz"
        if compressed:
            rigs.save(rig, path)
        else:
            np.savez(path, neutral=rig.neutral, deltas=rig.deltas, triangles=rig.triangles, names=["lift"])
        return path.read_bytes()


@FUZZ
@given(data=st.one_of(mutated(npz_bytes(True)), mutated(npz_bytes(False))))
def test_mutated_npz_archives_load_or_are_refused(data: bytes) -> None:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "rig.npz"
        path.write_bytes(data)
        load_or_refuse(path)


TARGET = b"# eyelid\n5 0 -0.5 0\n6 0 -0.25 0.0\n"


@FUZZ
@given(target=mutated(TARGET), gz=st.booleans())
def test_mutated_target_sets_load_or_are_refused(target: bytes, gz: bool) -> None:
    import gzip

    with tempfile.TemporaryDirectory() as folder:
        root = Path(folder) / "set"
        root.mkdir()
        (root / "base.obj").write_bytes(NEUTRAL)
        name = "blink.target.gz" if gz else "blink.target"
        (root / name).write_bytes(gzip.compress(target) if gz else target)
        loaded = load_or_refuse(root)
        if loaded is not None:
            assert loaded.names == ("blink",)
