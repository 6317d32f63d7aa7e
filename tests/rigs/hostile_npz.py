"""Hostile-input corpus (`tests/rigs/test_hostile_inputs.py`): native .npz rigs."""

from __future__ import annotations

import io
import os
import struct
import warnings
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np

from tests.rigs.hostile_corpus import add, case
from tests.rigs.hostile_gltf import HEAVY

NPZ_NEUTRAL = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]])


def npz_arrays(**changes) -> dict:
    arrays = {
        "neutral": NPZ_NEUTRAL,
        "deltas": np.zeros((2, 4, 3)),
        "triangles": np.array([[0, 1, 2], [1, 3, 2]]),
        "names": np.array(["lift", "rest"]),
    }
    arrays.update(changes)
    return {key: value for key, value in arrays.items() if value is not None}


def write_npz(folder: Path, arrays: dict, *, compressed: bool = False) -> Path:
    path = folder / "rig.npz"
    with open(path, "wb") as stream:
        (np.savez_compressed if compressed else np.savez)(stream, **arrays)
    return path


def npz_case(name: str, error: str, **changes) -> None:
    add(f"npz/{name}", lambda folder: (write_npz(folder, npz_arrays(**changes)), {}), error)


for label, changes, error in [
    (
        "complex-deltas",
        {"deltas": np.zeros((2, 4, 3), dtype=complex) + 1j},
        r"rig\.npz: deltas must hold real numbers, got dtype complex128",
    ),
    (
        "bool-triangles",
        {"triangles": np.ones((2, 3), dtype=bool)},
        r"rig\.npz: triangles must hold integer vertex indices, got dtype bool",
    ),
    (
        "fractional-triangles",
        {"triangles": np.array([[0, 1, 2.5], [1, 3, 2]])},
        r"rig\.npz: triangles must hold integer vertex indices",
    ),
    (
        "nan-triangles",
        {"triangles": np.array([[0, 1, np.nan], [1, 3, 2]])},
        r"rig\.npz: triangles must hold integer vertex indices",
    ),
    (
        "string-neutral",
        {"neutral": np.array([["a", "b", "c"]] * 4)},
        r"rig\.npz: neutral must hold real numbers, got dtype <U1",
    ),
    (
        "bool-neutral",
        {"neutral": np.ones((4, 3), dtype=bool)},
        r"rig\.npz: neutral must hold real numbers, got dtype bool",
    ),
    (
        "datetime-deltas",
        {"deltas": np.zeros((2, 4, 3), dtype="datetime64[s]")},
        r"rig\.npz: deltas must hold real numbers",
    ),
    (
        "structured-neutral",
        {"neutral": np.zeros(4, dtype=[("x", "f8"), ("y", "f8"), ("z", "f8")])},
        r"rig\.npz: neutral must hold real numbers",
    ),
    (
        "object-names",
        {"names": np.array(["a", 1], dtype=object)},
        r"rig\.npz: key 'names' cannot be read without pickle",
    ),
    ("number-names", {"names": np.array([1.0, 2.0])}, r"rig\.npz: 'names' must be a 1-D string array"),
    ("2d-names", {"names": np.array([["a", "b"]])}, r"rig\.npz: 'names' must be a 1-D string array"),
    (
        "bytes-names-not-utf8",
        {"names": np.array([b"\xff\xfe", b"ok"])},
        r"rig\.npz: 'names' holds bytes that are not UTF-8 text",
    ),
    ("duplicate-names", {"names": np.array(["a", "a"])}, r"rig\.npz: duplicate blendshape name 'a'"),
    ("empty-name", {"names": np.array(["", "b"])}, r"rig\.npz: a blendshape has an empty name"),
    ("too-few-names", {"names": np.array(["a"])}, r"rig\.npz: 1 names for 2 blendshapes"),
    (
        "deltas-wrong-vertices",
        {"deltas": np.zeros((2, 5, 3))},
        r"rig\.npz: deltas must have shape \(K, 4, 3\)",
    ),
    ("deltas-4d", {"deltas": np.zeros((2, 4, 3, 1))}, r"rig\.npz: deltas must have shape"),
    ("neutral-0d", {"neutral": np.float64(3.0)}, r"rig\.npz: neutral must have shape \(N, 3\), got \(\)"),
    (
        "neutral-empty",
        {"neutral": np.zeros((0, 3)), "deltas": np.zeros((2, 0, 3))},
        r"rig\.npz: neutral has no vertices",
    ),
    (
        "neutral-nan",
        {"neutral": np.full((4, 3), np.nan)},
        r"rig\.npz: neutral has a non-finite coordinate at vertex 0",
    ),
    (
        "deltas-inf",
        {"deltas": np.full((2, 4, 3), np.inf)},
        r"rig\.npz: blendshape 'lift' has a non-finite displacement",
    ),
    (
        "triangle-out-of-range",
        {"triangles": np.array([[0, 1, 9]])},
        r"rig\.npz: triangle 0 \[0, 1, 9\] indexes outside 0\.\.3",
    ),
    (
        "triangle-negative",
        {"triangles": np.array([[0, -1, 2]])},
        r"rig\.npz: triangle 0 \[0, -1, 2\] indexes outside",
    ),
    (
        "triangle-uint64-huge",
        {"triangles": np.array([[0, 1, 2**64 - 1]], dtype=np.uint64)},
        r"rig\.npz: triangle 0 .* indexes outside",
    ),
    (
        "triangles-wrong-shape",
        {"triangles": np.zeros((2, 4), dtype=int)},
        r"rig\.npz: triangles must have shape \(T, 3\)",
    ),
    (
        "region-out-of-range",
        {"region__lip": np.array([0, 99])},
        r"rig\.npz: region 'lip' indexes outside 0\.\.3",
    ),
    (
        "region-fractional",
        {"region__lip": np.array([0.5])},
        r"rig\.npz: region 'lip' must hold integer vertex indices",
    ),
    (
        "region-complex",
        {"region__lip": np.array([1j])},
        r"rig\.npz: region 'lip' must hold integer vertex indices, got dtype complex128",
    ),
    (
        "region-mask-shape",
        {"region__lip": np.ones(7, dtype=bool)},
        r"rig\.npz: region 'lip' mask has shape \(7,\)",
    ),
    ("missing-key", {"deltas": None}, r"rig\.npz: missing key 'deltas'"),
    ("unexpected-key", {"faces": np.zeros(3)}, r"rig\.npz: unexpected key 'faces'"),
]:
    npz_case(label, error, **changes)


def zip_bytes(members: dict[str, bytes], *, method: int = zipfile.ZIP_STORED) -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression=method) as archive:
        for name, data in members.items():
            archive.writestr(name, data)
    return buffer.getvalue()


def npy_bytes(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, array)
    return buffer.getvalue()


def npz_members(**changes) -> dict[str, bytes]:
    return {f"{key}.npy": npy_bytes(value) for key, value in npz_arrays(**changes).items()}


def patch_header(data: bytes, old: bytes, new: bytes) -> bytes:
    """Replace ``old`` by ``new`` (same length) in an .npy header."""
    assert len(old) == len(new) and old in data
    return data.replace(old, new, 1)


def raw_npz_case(name: str, make: Callable[[], bytes], error: str, **kwargs) -> None:
    def build(folder: Path) -> tuple[Path, dict]:
        path = folder / "rig.npz"
        path.write_bytes(make())
        return path, {}

    add(f"npz/{name}", build, error, **kwargs)


def claim_218_tib() -> bytes:
    """``deltas.npy`` with its data, but a header claiming (1, 10**13, 3) float64: 218 TiB."""
    members = npz_members()
    data = members["deltas.npy"]
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        header, {"descr": "<f8", "fortran_order": False, "shape": (1, 10**13, 3)}
    )
    members["deltas.npy"] = header.getvalue() + data[data.index(b"\n") + 1 :]
    return zip_bytes(members)


def crc_flip() -> bytes:
    data = bytearray(zip_bytes(npz_members()))
    index = data.index(b"\x00\x00\x00\x00\x00\x00\xf0\x3f")  # a float 1.0 in neutral's data
    data[index + 7] ^= 0x01
    return bytes(data)


def deflate_flip() -> bytes:
    data = bytearray(
        zip_bytes(npz_members(deltas=np.arange(24.0).reshape(2, 4, 3)), method=zipfile.ZIP_DEFLATED)
    )
    start = data.index(b"deltas.npy") + len("deltas.npy") + 20
    for offset in range(start, start + 40, 3):
        data[offset] ^= 0xFF
    return bytes(data)


def lying_directory(size: int, method: int = zipfile.ZIP_STORED) -> bytes:
    """An archive whose local header and central directory claim ``size`` bytes for ``deltas.npy``."""
    data = bytearray(zip_bytes(npz_members(), method=method))
    archive = zipfile.ZipFile(io.BytesIO(bytes(data)))
    info = archive.getinfo("deltas.npy")
    struct.pack_into("<I", data, info.header_offset + 22, size)  # local header: uncompressed size
    position = 0
    while True:  # the central directory entry of deltas.npy
        position = data.index(b"PK\x01\x02", position)
        name_length = struct.unpack_from("<H", data, position + 28)[0]
        if data[position + 46 : position + 46 + name_length] == b"deltas.npy":
            struct.pack_into("<I", data, position + 24, size)
            break
        position += 4
    return bytes(data)


def method_bzip2() -> bytes:
    return zip_bytes(npz_members(), method=zipfile.ZIP_BZIP2)


for label, make, error in [
    (
        "header-claims-218-TiB",
        claim_218_tib,
        r"rig\.npz: key 'deltas': its header claims shape \(1, 10000000000000, 3\) of float64 "
        r"\(218\.3 TiB\), but the archive holds 192 bytes",
    ),
    (
        "header-claims-fewer-bytes",
        lambda: zip_bytes(
            {
                **npz_members(),
                "deltas.npy": patch_header(npy_bytes(np.zeros((2, 4, 3))), b"(2, 4, 3)", b"(1, 4, 3)"),
            }
        ),
        r"key 'deltas': its header claims shape \(1, 4, 3\)",
    ),
    (
        "header-dtype-lies",
        lambda: zip_bytes(
            {**npz_members(), "deltas.npy": patch_header(npy_bytes(np.zeros((2, 4, 3))), b"<f8", b"<f4")}
        ),
        r"key 'deltas': its header claims shape \(2, 4, 3\) of float32",
    ),
    (
        "header-garbage",
        lambda: zip_bytes({**npz_members(), "deltas.npy": b"\x93NUMPY\x01\x00\x10\x00{'x': 1}      \n"}),
        r"rig\.npz: key 'deltas' is corrupt",
    ),
    (
        "header-version-3",
        lambda: zip_bytes({**npz_members(), "deltas.npy": b"\x93NUMPY\x03\x00" + npy_bytes(np.zeros(3))[8:]}),
        r"key 'deltas'",
    ),
    (
        "header-version-9",
        lambda: zip_bytes({**npz_members(), "deltas.npy": b"\x93NUMPY\x09\x00" + npy_bytes(np.zeros(3))[8:]}),
        r"key 'deltas' is corrupt|format version",
    ),
    (
        "header-negative-shape",
        lambda: zip_bytes(
            {
                **npz_members(),
                "deltas.npy": patch_header(npy_bytes(np.zeros((2, 4, 3))), b"(2, 4, 3)", b"(2,-4, 3)"),
            }
        ),
        r"key 'deltas'",
    ),
    (
        "member-not-npy",
        lambda: zip_bytes({**npz_members(), "readme.txt": b"hello"}),
        r"rig\.npz: member 'readme\.txt' is not a \.npy array",
    ),
    (
        "names-huge-dtype",
        lambda: zip_bytes(
            {
                **npz_members(),
                "names.npy": patch_header(npy_bytes(np.array(["lift", "rest"])), b"<U4", b"<U9"),
            }
        ),
        r"key 'names': its header claims",
    ),
    ("crc-mismatch", crc_flip, r"rig\.npz: key 'neutral' is corrupt \(Bad CRC-32"),
    ("deflate-corrupt", deflate_flip, r"rig\.npz: key 'deltas'"),
    (
        "directory-lies-stored",
        lambda: lying_directory(2**32 - 1),
        r"rig\.npz: key 'deltas': claims 4\.0 GiB from .* of compressed data",
    ),
    (
        "directory-lies-deflated",
        lambda: lying_directory(2**31, zipfile.ZIP_DEFLATED),
        r"key 'deltas': claims 2\.0 GiB from",
    ),
    ("bzip2-member", method_bzip2, r"key '\w+': compressed with zip method 12 \(only store and deflate\)"),
    ("truncated-archive", lambda: zip_bytes(npz_members())[:300], r"rig\.npz: not a NumPy \.npz archive"),
    ("single-npy", lambda: npy_bytes(NPZ_NEUTRAL), r"rig\.npz: holds a single array, not a rig archive"),
    (
        "text-file",
        lambda: b"neutral = [[0, 0, 0]]\n",
        r"rig\.npz: not a NumPy \.npz archive \(not a zip file",
    ),
    ("empty-file", lambda: b"", r"rig\.npz: not a NumPy \.npz archive"),
    ("zip-of-nothing", lambda: zip_bytes({}), r"rig\.npz: missing key 'neutral'"),
]:
    raw_npz_case(label, make, error, heavy=label in HEAVY)


@case("npz/duplicate-member", r"rig\.npz: key 'deltas' appears twice in the archive")
def _duplicate_member(folder: Path) -> tuple[Path, dict]:
    path = folder / "rig.npz"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # (zipfile warns about the duplicate it is asked to write)
        with zipfile.ZipFile(path, "w") as archive:
            for name, data in npz_members().items():
                archive.writestr(name, data)
            archive.writestr("deltas.npy", npy_bytes(np.ones((2, 4, 3))))
    return path, {}


def npz_special(kind: str) -> Callable[[Path], tuple[Path, dict]]:
    def build(folder: Path) -> tuple[Path, dict]:
        path = folder / "rig.npz"
        if kind == "fifo":
            os.mkfifo(path)
        elif kind == "dev-zero":
            path.symlink_to("/dev/zero")
        elif kind == "loop":
            path.symlink_to(path)
        return path, {}

    return build


add("npz/fifo", npz_special("fifo"), r"rig\.npz: is a FIFO \(named pipe\), not a regular file")
add("npz/dev-zero", npz_special("dev-zero"), r"rig\.npz: is a character device, not a regular file")
add("npz/symlink-loop", npz_special("loop"), r"rig\.npz: symbolic link loop")
add(
    "npz/dev-zero-forced-format",
    lambda folder: (Path("/dev/zero"), {"format": "npz"}),
    r"/dev/zero: is a character device, not a regular file",
)
