"""A corpus of malformed and hostile rig files, generated here: every one is refused with a one-line
`RigError` naming the file and the problem, or, when merely doubtful, loads correctly with a `RigWarning`.

Each case runs under a hang guard (an alarm that raises, and a faulthandler backstop that dumps the stack
and exits) and under tracemalloc (peak of Python and NumPy allocations under 1 GB); the cases that would
take gigabytes if the readers trusted the files also run in a child process whose address space is
capped at 1 GiB above what importing the package takes.
"""

from __future__ import annotations

import faulthandler
import gzip
import io
import json
import os
import struct
import subprocess
import sys
import tracemalloc
import warnings
import zipfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

import rigs
from rigs import RigError
from rigs._rig import RigWarning
from tests.rigs.rig_files import GRID, QUADS, hang_alarm

#: Seconds one load may take before the guard calls it a hang.
HANG_SECONDS = 20
#: Peak memory one load may take.
PEAK_BYTES = 2**30


@dataclass(frozen=True)
class Case:
    """One malformed input: ``build(folder)`` writes it and returns the path to load (and options).

    ``error`` is the pattern the RigError must match; with ``warning`` instead, the input loads with a
    RigWarning matching it and ``check(rig)`` holds.
    """

    name: str
    build: Callable[[Path], tuple[Path, dict]]
    error: str | None = None
    warning: str | None = None
    check: Callable[[rigs.Rig], bool] = field(default=lambda rig: True)
    heavy: bool = False


CASES: list[Case] = []


def case(name: str, error: str | None = None, **kwargs) -> Callable:
    """Register the decorated builder as a corpus case."""

    def register(build: Callable[[Path], tuple[Path, dict]]) -> Callable:
        CASES.append(Case(name, build, error, **kwargs))
        return build

    return register


def add(name: str, build: Callable[[Path], tuple[Path, dict]], error: str | None = None, **kwargs) -> None:
    CASES.append(Case(name, build, error, **kwargs))


# == OBJ folders ===========================================================================================
def obj_text(vertices: np.ndarray = GRID, faces=QUADS) -> str:
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in np.asarray(vertices, dtype=float).tolist()]
    lines += ["f " + " ".join(str(i + 1) for i in face) for face in faces]
    return "\n".join(lines) + "\n"


def smile() -> np.ndarray:
    moved = GRID.copy()
    moved[5] += [0, 0, 0.3]
    return moved


def obj_folder(folder: Path, *, neutral: str | bytes | None = None, shapes: dict | None = None) -> Path:
    """A rig folder: ``neutral.obj`` and one OBJ per shape (text or bytes as given, defaults valid)."""
    rig = folder / "rig"
    rig.mkdir()
    written = {"neutral": obj_text() if neutral is None else neutral}
    written.update({"smile": obj_text(smile())} if shapes is None else shapes)
    for name, content in written.items():
        target = rig / f"{name}.obj"
        target.write_bytes(content if isinstance(content, bytes) else content.encode())
    return rig


def neutral_case(name: str, text: str | bytes, error: str) -> None:
    add(f"obj/neutral-{name}", lambda folder: (obj_folder(folder, neutral=text), {}), error)


def shape_case(name: str, text: str | bytes, error: str) -> None:
    add(f"obj/shape-{name}", lambda folder: (obj_folder(folder, shapes={"smile": text}), {}), error)


VALID = obj_text()
FACES = VALID[VALID.index("\nf ") + 1 :]
VERTICES = VALID[: VALID.index("\nf ") + 1]


def long_line() -> str:
    return "v " + "1 " * 5_000_000 + "\n"  # 10 MB, 5M values


add(
    "obj/neutral-10MB-vertex-line",
    lambda folder: (obj_folder(folder, neutral=long_line() + VALID), {}),
    r"neutral\.obj:1: vertex has more than 6 values",
    heavy=True,
)
add(
    "obj/shape-10MB-vertex-line",
    lambda folder: (obj_folder(folder, shapes={"smile": long_line() + VALID}), {}),
    r"smile\.obj:1: vertex has more than 6 values",
    heavy=True,
)
add(
    "obj/neutral-10MB-face-line",
    lambda folder: (obj_folder(folder, neutral=VALID + "f " + "1 2 3 " * 1_000_000 + "\n"), {}),
    r"neutral\.obj:26: face has 3000000 corners, more than the mesh's 16 vertices",
    heavy=True,
)
for label, text, error in [
    (
        "index-past-64-bits",
        VERTICES + "f 1 2 99999999999999999999999\n",
        r"neutral\.obj:17: face indexes a vertex outside 1\.\.16",
    ),
    ("index-2**63", VERTICES + f"f 1 2 {2**63}\n", r"neutral\.obj:17: face indexes a vertex outside"),
    ("index-zero", VERTICES + "f 0 1 2\n", r"neutral\.obj:17: face indexes a vertex outside"),
    ("index-past-end", VERTICES + "f 1 2 17\n", r"neutral\.obj:17: face indexes a vertex outside 1\.\.16"),
    ("relative-before-vertices", "f -1 -2 -3\n" + VALID, r"neutral\.obj:1: face indexes a vertex outside"),
    ("two-corner-face", VERTICES + "f 1 2\n", r"neutral\.obj:17: face needs at least 3 corners"),
    ("letter-index", VERTICES + "f 1 2 a/1\n", r"neutral\.obj:17: face has a malformed vertex index"),
    ("slash-only-index", VERTICES + "f 1 2 /3\n", r"neutral\.obj:17: face has a malformed vertex index"),
    ("5000-digit-index", VERTICES + "f 1 2 " + "9" * 5000 + "\n", r"neutral\.obj:17: face has a malformed"),
    ("letter-coordinate", "v 1 x 0\n" + VALID, r"neutral\.obj:1: vertex has a non-numeric coordinate"),
    ("two-coordinates", "v 0 0\n" + VALID, r"neutral\.obj:1: vertex needs x y z"),
    ("nan-coordinate", "v 0 nan 0\n" + VALID, r"neutral\.obj:1: vertex 0 has a non-finite coordinate"),
    ("inf-coordinate", "v inf 0 0\n" + VALID, r"neutral\.obj:1: vertex 0 has a non-finite coordinate"),
    ("overflowing-coordinate", "v 1e999 0 0\n" + VALID, r"neutral\.obj:1: vertex 0 has a non-finite"),
    ("no-vertices", "# nothing here\n", r"neutral\.obj: no vertices"),
    ("empty-file", "", r"neutral\.obj: no vertices"),
    ("no-faces", VERTICES, r"neutral\.obj: the neutral mesh has no faces"),
    (
        "binary-garbage",
        bytes(np.random.default_rng(0).integers(0, 256, 4096, dtype=np.uint8)),
        r"neutral\.obj",
    ),
    ("utf16", VALID.encode("utf-16"), r"neutral\.obj: no vertices"),
    ("nul-bytes", VALID.replace("v 1.0", "v 1\x00.0", 1), r"neutral\.obj:\d+: vertex has a non-numeric"),
    (
        "1000-groups",
        "g " + " ".join(f"g{i}" for i in range(1000)) + "\n" + VALID,
        r"'g' line names more than",
    ),
    ("continuation-at-end", VALID + "v 1 \\", r"neutral\.obj:\d+: vertex needs x y z"),
    (
        "cr-only-bad-vertex",
        VALID.replace("\n", "\r") + "v 1 y 2\r",
        r"neutral\.obj:\d+: vertex has a non-numeric",
    ),
    ("relative-past-start", VERTICES + "f -1 -2 -17\n", r"neutral\.obj:17: face indexes a vertex outside"),
    (
        "corners-repeat",
        VERTICES + "f " + "1 2 3 " * 6 + "\n",
        r"neutral\.obj:17: face has 18 corners, more than",
    ),
]:
    neutral_case(label, text, error)

for label, text, error in [
    (
        "fewer-vertices",
        obj_text(GRID[:-1], []),
        r"smile\.obj: 15 vertices, but the neutral neutral\.obj has 16",
    ),
    ("more-vertices", obj_text(np.vstack([GRID, [[9, 9, 9]]]), []), r"smile\.obj: 17 vertices, but"),
    ("other-connectivity", obj_text(GRID, [q[::-1] for q in QUADS]), r"smile\.obj: connectivity differs"),
    (
        "extra-face",
        VERTICES + "f 1 2 3\n" + FACES,
        r"smile\.obj: 10 faces, but the neutral neutral\.obj has 9",
    ),
    ("nan", VALID.replace("v 1.0 0.0 0.0", "v 1.0 nan 0.0"), r"smile\.obj:2: vertex 1 has a non-finite"),
    ("empty", "", r"smile\.obj: no vertices"),
    ("garbage", b"\x89PNG\r\n\x1a\n" + bytes(range(256)) * 8, r"smile\.obj"),
    ("bad-index", VERTICES + "f 1 2 x\n", r"smile\.obj:17: face has a malformed vertex index"),
]:
    shape_case(label, text, error)


def tiny_folder(folder: Path, shape: Callable[[rigs.Rig], np.ndarray]) -> Path:
    """The generated ``tiny`` rig as OBJs, plus a shape ``odd.obj`` with the positions ``shape(rig)``."""
    rig = rigs.generate("tiny").subset(["jawOpen"])
    path = rigs.save(rig, folder / "tiny")
    (path / "rig.json").unlink()
    (path / "odd.obj").write_text(obj_text(shape(rig), rig.triangles.tolist()))
    return path


add(
    "obj/shape-shuffled-vertex-order",
    lambda folder: (
        tiny_folder(
            folder,
            lambda rig: (rig.neutral + rig.deltas[0])[np.random.default_rng(1).permutation(rig.n_vertices)],
        ),
        {},
    ),
    r"odd\.obj: its vertices are not in the order of the neutral neutral\.obj \(\d+% of the mesh's edges",
)
add(
    "obj/shape-reversed-vertex-order",
    lambda folder: (tiny_folder(folder, lambda rig: rig.neutral[::-1]), {}),
    warning=r"odd\.obj: \d+% of its vertices move further than 0\.25 of the neutral's size",
    check=lambda rig: np.allclose(rig.deltas[1], rig.neutral[::-1] - rig.neutral),
)
add(
    "obj/shape-rescaled",
    lambda folder: (tiny_folder(folder, lambda rig: rig.neutral * 1.6), {}),
    warning=r"odd\.obj: \d+% of the mesh's edges change length by more than 25% against the neutral",
    check=lambda rig: rig.names == ("jawOpen", "odd") and np.allclose(rig.deltas[1], rig.neutral * 0.6),
)


def special_entry(kind: str, name: str = "smile.obj") -> Callable[[Path], tuple[Path, dict]]:
    """A rig folder whose ``name`` is a FIFO, a dangling or looping link, a link outside, or a folder."""

    def build(folder: Path) -> tuple[Path, dict]:
        rig = obj_folder(folder, shapes={})
        entry = rig / name
        entry.unlink(missing_ok=True)
        outside = folder / "outside.obj"
        outside.write_text(obj_text(smile()))
        if kind == "fifo":
            os.mkfifo(entry)
        elif kind == "dangling":
            entry.symlink_to(rig / "gone.obj")
        elif kind == "loop":
            entry.symlink_to(entry)
        elif kind == "outside":
            entry.symlink_to(outside)
        elif kind == "relative-outside":
            entry.symlink_to(Path("..") / "outside.obj")
        elif kind == "etc":
            entry.symlink_to("/etc/passwd")
        elif kind == "dev-zero":
            entry.symlink_to("/dev/zero")
        elif kind == "folder":
            entry.mkdir()
        if name != "neutral.obj":
            (rig / "blink.obj").write_text(obj_text(smile()))
        return rig, {}

    return build


for kind, reason in [
    ("fifo", r"is a FIFO \(named pipe\), not a regular file"),
    ("dangling", r"symbolic link to '.*gone\.obj', which does not exist"),
    ("loop", r"symbolic link loop"),
    ("outside", r"resolves to .*outside\.obj, outside the rig's folder"),
    ("relative-outside", r"resolves to .*outside\.obj, outside the rig's folder"),
    ("etc", r"resolves to /etc/passwd, outside the rig's folder"),
    ("dev-zero", r"is a character device, not a regular file"),
    ("folder", r"is a folder, not a regular file"),
]:
    add(f"obj/shape-entry-{kind}", special_entry(kind), rf"smile\.obj: {reason}")
    add(f"obj/neutral-entry-{kind}", special_entry(kind, "neutral.obj"), rf"neutral\.obj: {reason}")


def manifest_case(name: str, manifest: object, error: str | None = None, **kwargs) -> None:
    def build(folder: Path) -> tuple[Path, dict]:
        rig = obj_folder(folder)
        (folder / "secret.obj").write_text(obj_text(smile()))
        text = manifest if isinstance(manifest, str) else json.dumps(manifest)
        (rig / "rig.json").write_text(text)
        return rig, {}

    add(f"obj/manifest-{name}", build, error, **kwargs)


for label, manifest, error in [
    ("shape-leaves-folder", {"shapes": ["../secret"]}, r"rig\.json: '\.\./secret\.obj' leaves the folder"),
    ("shape-absolute", {"shapes": ["/etc/hostname"]}, r"rig\.json: '/etc/hostname\.obj' is an absolute path"),
    ("shape-nul", {"shapes": ["smi\x00le"]}, r"rig\.json: file name .* holds a NUL byte"),
    ("shape-number", {"shapes": [7]}, r"rig\.json: blendshape names must be non-empty strings, got 7"),
    ("shape-empty-name", {"shapes": [""]}, r"rig\.json: blendshape names must be non-empty strings"),
    ("shapes-not-list", {"shapes": "smile"}, r"rig\.json: expected an object with a 'shapes' list"),
    (
        "neutral-leaves-folder",
        {"neutral": "../secret.obj", "shapes": ["smile"]},
        r"rig\.json: '\.\./secret\.obj' leaves",
    ),
    (
        "neutral-absolute",
        {"neutral": "/etc/hostname", "shapes": ["smile"]},
        r"rig\.json: '/etc/hostname' is an absolute",
    ),
    (
        "neutral-number",
        {"neutral": 3, "shapes": ["smile"]},
        r"rig\.json: 'neutral' must be a file name, got 3",
    ),
    ("not-json", "{shapes: [smile]", r"rig\.json: not a readable JSON manifest"),
    ("deep-nesting", "[" * 100_000 + "]" * 100_000, r"rig\.json: not a readable JSON manifest"),
    ("top-level-list", "[1, 2]", r"rig\.json: expected an object with a 'shapes' list"),
    ("regions-list", {"shapes": ["smile"], "regions": [1, 2]}, r"rig\.json: 'regions' must be an object"),
    (
        "region-strings",
        {"shapes": ["smile"], "regions": {"lip": ["a", "b"]}},
        r"rig: region 'lip' must hold integer vertex indices",
    ),
    (
        "region-ragged",
        {"shapes": ["smile"], "regions": {"lip": [[1, 2], [3]]}},
        r"rig: region 'lip' is not an array",
    ),
    (
        "region-out-of-range",
        {"shapes": ["smile"], "regions": {"lip": [99]}},
        r"rig: region 'lip' indexes outside 0\.\.15",
    ),
    (
        "region-fractional",
        {"shapes": ["smile"], "regions": {"lip": [1.5]}},
        r"rig: region 'lip' must hold integer",
    ),
    ("units-number", {"shapes": ["smile"], "units": 100}, r"rig\.json: 'units' must be a string, got 100"),
    (
        "shape-missing",
        {"shapes": ["smile", "frown"]},
        r"frown\.obj: blendshape listed in rig\.json but the file is missing",
    ),
]:
    manifest_case(label, manifest, error)

manifest_case(
    "unlisted-shape",
    {"shapes": []},
    warning=r"rig: smile\.obj not listed in rig\.json's shapes; left out",
    check=lambda rig: rig.names == (),
)


def manifest_entry(kind: str) -> Callable[[Path], tuple[Path, dict]]:
    def build(folder: Path) -> tuple[Path, dict]:
        rig = obj_folder(folder)
        if kind == "fifo":
            os.mkfifo(rig / "rig.json")
        else:
            (rig / "rig.json").symlink_to(rig / "gone.json")
        return rig, {}

    return build


add("obj/manifest-fifo", manifest_entry("fifo"), r"rig\.json: is a FIFO \(named pipe\), not a regular file")
add("obj/manifest-dangling", manifest_entry("dangling"), r"rig\.json: symbolic link to .*gone\.json")


@case("obj/duplicate-stems", r"duplicate blendshape name 'smile'")
def _duplicate_stems(folder: Path) -> tuple[Path, dict]:
    rig = obj_folder(folder)
    (rig / "smile.OBJ").write_text(obj_text(smile()))
    return rig, {}


@case("obj/neutral-path-is-fifo", r"neutral\.obj: is a FIFO")
def _neutral_path_fifo(folder: Path) -> tuple[Path, dict]:
    rig = obj_folder(folder)
    (rig / "neutral.obj").unlink()
    os.mkfifo(rig / "neutral.obj")
    return rig / "neutral.obj", {}


# == glTF (.gltf JSON) =====================================================================================
GLTF_NEUTRAL = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0], [2, 1, 0]], dtype=np.float32)
GLTF_DELTAS = np.zeros((2, 6, 3), dtype=np.float32)
GLTF_DELTAS[0, 2] = [0, 0.25, 0.5]
GLTF_DELTAS[1, 4] = [0, 0, -0.125]
GLTF_INDICES = np.array([0, 1, 2, 0, 2, 3, 1, 4, 5, 1, 5, 2], dtype=np.uint32)


def gltf_document() -> tuple[dict, bytes]:
    """A valid glTF: one mesh, one primitive, two morph targets; accessors 0 POSITION, 1-2 targets,
    3 indices; buffer views alike."""
    parts = [GLTF_NEUTRAL, GLTF_DELTAS[0], GLTF_DELTAS[1], GLTF_INDICES]
    blob, views = b"", []
    for array in parts:
        data = array.tobytes()
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data)})
        blob += data
    accessors = [{"bufferView": k, "componentType": 5126, "count": 6, "type": "VEC3"} for k in range(3)] + [
        {"bufferView": 3, "componentType": 5125, "count": 12, "type": "SCALAR"}
    ]
    document = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": "Head"}],
        "meshes": [
            {
                "name": "Face",
                "primitives": [
                    {
                        "attributes": {"POSITION": 0},
                        "indices": 3,
                        "targets": [{"POSITION": 1}, {"POSITION": 2}],
                    }
                ],
                "extras": {"targetNames": ["jawOpen", "smile"]},
            }
        ],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(blob), "uri": "mesh.bin"}],
    }
    return document, blob


def write_gltf(folder: Path, document: dict, blob: bytes, *, text: str | None = None) -> Path:
    path = folder / "face.gltf"
    (folder / "mesh.bin").write_bytes(blob)
    path.write_text(text if text is not None else json.dumps(document))
    return path


def gltf_case(name: str, mutate: Callable[[dict, Path], object], error: str | None = None, **kwargs) -> None:
    """A case from the valid document changed in place by ``mutate(document, folder)``."""

    def build(folder: Path) -> tuple[Path, dict]:
        document, blob = gltf_document()
        mutate(document, folder)
        return write_gltf(folder, document, blob), {}

    add(f"gltf/{name}", build, error, **kwargs)


def setter(path: str, value: object) -> Callable[[dict, Path], None]:
    """Set ``document[a][b]...`` for the dotted ``path`` (list indices as numbers); ``...`` deletes."""

    def mutate(document: dict, folder: Path) -> None:
        keys = [int(k) if k.isdigit() else k for k in path.split(".")]
        holder = document
        for key in keys[:-1]:
            holder = holder[key]
        if value is ...:
            del holder[keys[-1]]
        else:
            holder[keys[-1]] = value

    return mutate


def uri(value: str) -> Callable[[dict, Path], None]:
    def mutate(document: dict, folder: Path) -> None:
        (folder.parent / "secret.bin").write_bytes(gltf_document()[1])  # a real buffer, outside the folder
        document["buffers"][0]["uri"] = value

    return mutate


def uri_entry(kind: str) -> Callable[[dict, Path], None]:
    def mutate(document: dict, folder: Path) -> None:
        entry = folder / "link.bin"
        secret = folder.parent / "secret.bin"
        secret.write_bytes(gltf_document()[1])
        if kind == "fifo":
            os.mkfifo(entry)
        elif kind == "outside":
            entry.symlink_to(secret)
        elif kind == "dangling":
            entry.symlink_to(folder / "gone.bin")
        elif kind == "loop":
            entry.symlink_to(entry)
        elif kind == "dev-zero":
            entry.symlink_to("/dev/zero")
        elif kind == "folder":
            entry.mkdir()
        document["buffers"][0]["uri"] = "link.bin"

    return mutate


def sparse(
    count: int, *, view: int = 3, component: int = 5125, offset: int | None = None, values: bool = True
) -> Callable[[dict, Path], None]:
    """Give accessor 1 (the first morph target) ``count`` sparse substitutions: indices of component type
    ``component`` read from bufferView ``view`` (at byte ``offset``), values from bufferView 1 (or none)."""
    indices = {"bufferView": view, "componentType": component}
    if offset is not None:
        indices["byteOffset"] = offset
    substitutions = {"count": count, "indices": indices}
    if values:
        substitutions["values"] = {"bufferView": 1}
    return setter("accessors.1.sparse", substitutions)


PRIMITIVE = "meshes.0.primitives.0"
#: Cases that would allocate gigabytes (or read /dev/zero) if the reader trusted the file.
HEAVY = {
    "target-count-1e9-no-view",
    "neutral-count-1e9",
    "uri-dev-zero",
    "uri-link-dev-zero",
    "header-claims-218-TiB",
}
for label, mutate, error in [
    ("uri-dotdot", uri("../secret.bin"), r"face\.gltf: buffer 0 URI: '\.\./secret\.bin' leaves the folder"),
    ("uri-percent-dotdot", uri("%2e%2e/secret.bin"), r"buffer 0 URI: '\.\./secret\.bin' leaves the folder"),
    ("uri-percent-slash", uri("%2E%2E%2Fsecret.bin"), r"buffer 0 URI: '\.\./secret\.bin' leaves the folder"),
    ("uri-inner-dotdot", uri("sub/../../secret.bin"), r"buffer 0 URI: 'sub/\.\./\.\./secret\.bin' leaves"),
    ("uri-absolute", uri("/etc/hostname"), r"buffer 0 URI: '/etc/hostname' is an absolute path"),
    ("uri-percent-absolute", uri("%2Fetc%2Fhostname"), r"buffer 0 URI: '/etc/hostname' is an absolute path"),
    ("uri-dev-zero", uri("/dev/zero"), r"buffer 0 URI: '/dev/zero' is an absolute path"),
    ("uri-file-scheme", uri("file:///etc/hostname"), r"buffer 0: URI 'file:///etc/hostname' names a scheme"),
    (
        "uri-http",
        uri("http://127.0.0.1/mesh.bin"),
        r"buffer 0: URI 'http://127\.0\.0\.1/mesh\.bin' names a scheme",
    ),
    ("uri-drive-letter", uri("C:/mesh.bin"), r"buffer 0: URI 'C:/mesh\.bin' names a scheme"),
    ("uri-unc", uri("\\\\server\\share\\mesh.bin"), r"is an absolute path"),
    ("uri-nul", uri("mesh.bin%00.png"), r"buffer 0 URI: file name .* holds a NUL byte"),
    ("uri-ipv6-garbage", uri("http://[::1/mesh.bin"), r"buffer 0: URI .* is malformed"),
    ("uri-missing", uri("nothere.bin"), r"buffer 0 file .*nothere\.bin is missing"),
    ("uri-not-string", setter("buffers.0.uri", 5), r"buffer 0: 'uri' must be a string, got 5"),
    ("uri-fifo", uri_entry("fifo"), r"buffer 0: .*link\.bin: is a FIFO"),
    ("uri-link-outside", uri_entry("outside"), r"buffer 0: .*link\.bin: resolves to .*secret\.bin, outside"),
    ("uri-link-dangling", uri_entry("dangling"), r"buffer 0: .*link\.bin: symbolic link to .*gone\.bin"),
    ("uri-link-loop", uri_entry("loop"), r"buffer 0: .*link\.bin: symbolic link loop"),
    ("uri-link-dev-zero", uri_entry("dev-zero"), r"buffer 0: .*link\.bin: is a character device"),
    ("uri-folder", uri_entry("folder"), r"buffer 0: .*link\.bin: is a folder"),
    (
        "data-uri-no-comma",
        setter("buffers.0.uri", "data:application/octet-stream;base64"),
        r"malformed data URI",
    ),
    (
        "data-uri-bad-alphabet",
        setter("buffers.0.uri", "data:;base64,!!!!"),
        r"malformed base64 in its data URI",
    ),
    ("data-uri-bad-padding", setter("buffers.0.uri", "data:;base64,QUJD" + "A"), r"malformed base64"),
    ("data-uri-non-ascii", setter("buffers.0.uri", "data:;base64,QUJDé"), r"malformed base64"),
    (
        "data-uri-short",
        setter("buffers.0.uri", "data:;base64,QUJD"),
        r"buffer 0 holds 3 bytes, fewer than its byteLength",
    ),
    (
        "data-uri-percent-short",
        setter("buffers.0.uri", "data:,%00%01"),
        r"buffer 0 holds 2 bytes, fewer than",
    ),
    (
        "byte-length-zero",
        setter("buffers.0.byteLength", 0),
        r"buffer 0: 'byteLength' must be an integer >= 1",
    ),
    ("byte-length-negative", setter("buffers.0.byteLength", -5), r"'byteLength' must be an integer >= 1"),
    (
        "byte-length-string",
        setter("buffers.0.byteLength", "264"),
        r"'byteLength' must be an integer >= 1, got '264'",
    ),
    (
        "byte-length-huge",
        setter("buffers.0.byteLength", 10**15),
        r"buffer 0 holds 264 bytes, fewer than its byteLength",
    ),
    ("byte-length-missing", setter("buffers.0.byteLength", ...), r"buffer 0: 'byteLength' is missing"),
    ("buffers-missing", setter("buffers", ...), r"buffer 0 does not exist \(the file has 0\)"),
    (
        "no-uri-no-glb",
        setter("buffers.0.uri", ...),
        r"buffer 0 has no URI and the file has no GLB binary chunk",
    ),
    (
        "target-count-1e9-no-view",
        lambda d, f: d["accessors"][1].update(count=10**9, bufferView=None),
        r"target 0 has 1000000000 positions for 6 vertices",
    ),
    (
        "target-count-short",
        setter("accessors.1.count", 5),
        r"primitive 0: target 0 has 5 positions for 6 vertices",
    ),
    (
        "neutral-count-1e9",
        setter("accessors.0.count", 10**9),
        r"face\.gltf: .*1000000000 vertices would take|reads past the end",
    ),
    (
        "neutral-no-view",
        setter("accessors.0.bufferView", ...),
        r"POSITION: accessor 0 has no bufferView; the neutral positions must be stored",
    ),
    (
        "neutral-sparse-only",
        lambda d, f: d["accessors"][0].update(bufferView=None, sparse={"count": 1}),
        r"accessor 0 has no bufferView",
    ),
    (
        "count-negative",
        setter("accessors.1.count", -1),
        r"target 0 POSITION: accessor 1: 'count' must be an integer >= 0",
    ),
    ("count-float", setter("accessors.1.count", 6.0), r"'count' must be an integer >= 0, got 6\.0"),
    ("count-bool", setter("accessors.1.count", True), r"'count' must be an integer >= 0, got True"),
    ("count-missing", setter("accessors.0.count", ...), r"accessor 0: 'count' is missing"),
    (
        "component-double",
        setter("accessors.0.componentType", 5130),
        r"accessor 0 is 'VEC3' of component type 5130, expected VEC3",
    ),
    (
        "component-string",
        setter("accessors.1.componentType", "5126"),
        r"accessor 1 is 'VEC3' of component type '5126'",
    ),
    (
        "type-vec2",
        setter("accessors.0.type", "VEC2"),
        r"accessor 0 is 'VEC2' of component type 5126, expected VEC3",
    ),
    ("type-missing", setter("accessors.2.type", ...), r"accessor 2 is None of component type"),
    (
        "stride-small",
        setter("bufferViews.0.byteStride", 4),
        r"bufferView 0: byteStride 4 is smaller than the 12-byte elements",
    ),
    ("stride-zero", setter("bufferViews.1.byteStride", 0), r"byteStride 0 is smaller than the 12-byte"),
    ("stride-negative", setter("bufferViews.1.byteStride", -12), r"'byteStride' must be an integer >= 0"),
    ("stride-huge", setter("bufferViews.1.byteStride", 2**40), r"reads past the end of bufferView 1"),
    (
        "view-offset-past-buffer",
        setter("bufferViews.2.byteOffset", 10**6),
        r"reads past the end of bufferView 2",
    ),
    (
        "accessor-offset-negative",
        setter("accessors.1.byteOffset", -4),
        r"accessor 1: 'byteOffset' must be an integer >= 0",
    ),
    (
        "accessor-offset-past-view",
        setter("accessors.1.byteOffset", 64),
        r"reads past the end of bufferView 1",
    ),
    (
        "view-out-of-range",
        setter("accessors.1.bufferView", 9),
        r"bufferView 9 does not exist \(the file has 4\)",
    ),
    ("view-negative", setter("accessors.1.bufferView", -1), r"bufferView -1 does not exist"),
    ("view-fractional", setter("accessors.1.bufferView", 1.5), r"bufferView 1\.5 does not exist"),
    (
        "view-buffer-out-of-range",
        setter("bufferViews.0.buffer", 3),
        r"buffer 3 does not exist \(the file has 1\)",
    ),
    (
        "view-length-missing",
        setter("bufferViews.0.byteLength", ...),
        r"bufferView 0: 'byteLength' is missing",
    ),
    (
        "view-length-short",
        setter("bufferViews.0.byteLength", 8),
        r"POSITION: reads past the end of bufferView 0",
    ),
    (
        "indices-float",
        setter("accessors.3.componentType", 5126),
        r"indices: accessor 3 is 'SCALAR' of component type 5126, expected SCALAR of 5121/5123/5125",
    ),
    (
        "indices-signed",
        setter("accessors.3.componentType", 5122),
        r"indices: accessor 3 is 'SCALAR' of component type 5122",
    ),
    ("indices-not-triples", setter("accessors.3.count", 11), r"11 triangle indices is not a multiple of 3"),
    (
        "indices-no-view",
        setter("accessors.3.bufferView", ...),
        r"indices: accessor 3 has no bufferView: it holds no data",
    ),
    (
        "index-past-vertices",
        lambda d, f: (
            d["accessors"].append(
                {"bufferView": 0, "componentType": 5125, "count": 3, "type": "SCALAR", "byteOffset": 4}
            )
            or d["meshes"][0]["primitives"][0].update(indices=4)
        ),
        r"index \d+ is past the 6 vertices",
    ),
    ("indices-out-of-range", setter(f"{PRIMITIVE}.indices", 12), r"accessor 12 does not exist"),
    ("sparse-count-past", sparse(99), r"sparse: 99 substitutions for 6 elements"),
    ("sparse-repeated-index", sparse(2, offset=8), r"sparse: indices do not strictly increase"),
    (
        "sparse-index-past",
        sparse(1, view=0, offset=12),
        r"sparse: index 1065353216 is past the accessor's 6 elements",
    ),
    ("sparse-index-float", sparse(1, component=5126), r"sparse indices have component type 5126"),
    ("sparse-no-values", sparse(1, values=False), r"sparse: needs 'indices' and 'values'"),
    ("sparse-not-object", setter("accessors.1.sparse", [1, 2]), r"accessor 1: 'sparse' must be an object"),
    (
        "sparse-count-negative",
        setter("accessors.1.sparse", {"count": -2}),
        r"sparse: 'count' must be an integer >= 0",
    ),
    (
        "normalized-string",
        setter("accessors.0.normalized", "yes"),
        r"accessor 0: 'normalized' must be true or false",
    ),
    ("target-index-string", setter(f"{PRIMITIVE}.targets.0.POSITION", "1"), r"accessor '1' does not exist"),
    (
        "target-other-attribute-string",
        setter(f"{PRIMITIVE}.targets.0", {"NORMAL": "x"}),
        r"target 0 has an attribute that is not an accessor index",
    ),
    ("targets-not-list", setter(f"{PRIMITIVE}.targets", {"POSITION": 1}), r"'targets' must be an array"),
    ("target-not-object", setter(f"{PRIMITIVE}.targets", [1, 2]), r"every morph target must be an object"),
    ("no-targets", setter(f"{PRIMITIVE}.targets", []), r"face\.gltf: no mesh primitive has morph targets"),
    (
        "target-names-count",
        setter("meshes.0.extras.targetNames", ["a"]),
        r"extras\.targetNames has 1 names for 2 morph targets",
    ),
    (
        "target-names-not-list",
        setter("meshes.0.extras.targetNames", "ab"),
        r"extras\.targetNames has 'ab' names",
    ),
    (
        "target-names-number",
        setter("meshes.0.extras.targetNames", ["a", 5]),
        r"extras\.targetNames holds 5, not a name",
    ),
    (
        "target-names-duplicate",
        setter("meshes.0.extras.targetNames", ["a", "a"]),
        r"duplicate morph target name 'a'",
    ),
    (
        "target-names-empty",
        setter("meshes.0.extras.targetNames", ["", "b"]),
        r"face\.gltf: a blendshape has an empty name",
    ),
    (
        "extension-unknown",
        setter("extensionsRequired", ["EXT_unheard_of"]),
        r"requires extension 'EXT_unheard_of', which this reader does not implement",
    ),
    (
        "extension-instancing",
        setter("extensionsRequired", ["EXT_mesh_gpu_instancing"]),
        r"requires extension 'EXT_mesh_gpu_instancing'",
    ),
    (
        "extension-draco",
        setter("extensionsRequired", ["KHR_draco_mesh_compression"]),
        r"compressed with KHR_draco_mesh_compression",
    ),
    (
        "extensions-not-list",
        setter("extensionsRequired", "KHR_mesh_quantization"),
        r"'extensionsRequired' must be an array of extension names",
    ),
    ("extension-number", setter("extensionsRequired", [5]), r"'extensionsRequired' must be an array"),
    ("node-own-child", setter("nodes.0.children", [0]), r"the node hierarchy has a cycle \(parents 0 -> 0\)"),
    (
        "node-two-cycle",
        lambda d, f: d.update(nodes=[{"mesh": 0, "children": [1]}, {"children": [0]}]),
        r"the node hierarchy has a cycle",
    ),
    (
        "node-cycle-elsewhere",
        lambda d, f: d["nodes"].extend([{"children": [2]}, {"children": [3]}, {"children": [1]}]),
        r"the node hierarchy has a cycle",
    ),
    (
        "node-two-parents",
        lambda d, f: d["nodes"].extend([{"children": [0]}, {"children": [0]}]),
        r"node 0 is a child of both node 1 and node 2",
    ),
    ("node-child-out-of-range", setter("nodes.0.children", [7]), r"node 0 child: node 7 does not exist"),
    ("node-children-not-list", setter("nodes.0.children", 1), r"node 0: 'children' must be an array"),
    ("node-matrix-15", setter("nodes.0.matrix", [1.0] * 15), r"node 0 matrix must be 16 numbers"),
    ("node-matrix-string", setter("nodes.0.matrix", "identity"), r"node 0 matrix must be 16 numbers"),
    (
        "node-translation-nan",
        lambda d, f: d["nodes"][0].update(translation=[float("nan"), 0, 0]),
        r"node 0 translation holds a non-finite number",
    ),
    (
        "node-scale-overflow",
        lambda d, f: d.update(
            nodes=[{"mesh": 0, "scale": [1e200] * 3}, {"children": [0], "scale": [1e200] * 3}]
        ),
        r"node 0: its world matrix is not finite",
    ),
    ("node-rotation-bool", setter("nodes.0.rotation", [True, 0, 0, 1]), r"node 0 rotation must be 4 numbers"),
    ("nodes-not-list", setter("nodes", {"0": {}}), r"'nodes' must be an array of objects"),
    ("mode-lines", setter(f"{PRIMITIVE}.mode", 1), r"primitive 0: mode 1 \(LINES\) has no triangles"),
    ("mode-string", setter(f"{PRIMITIVE}.mode", "4"), r"primitive 0: 'mode' must be an integer, got '4'"),
    ("mode-unknown", setter(f"{PRIMITIVE}.mode", 9), r"mode 9 \(unknown\) has no triangles"),
    ("asset-missing", setter("asset", ...), r"face\.gltf: not a glTF 2\.0 file \(asset\.version None\)"),
    ("asset-version-1", setter("asset.version", "1.0"), r"not a glTF 2\.0 file \(asset\.version '1\.0'\)"),
    ("asset-version-number", setter("asset.version", 2), r"not a glTF 2\.0 file \(asset\.version 2\)"),
    ("meshes-not-list", setter("meshes", {"Face": 1}), r"'meshes' must be an array of objects"),
    ("meshes-empty", setter("meshes", []), r"face\.gltf: has no meshes"),
    ("primitives-missing", setter("meshes.0.primitives", ...), r"the chosen mesh has no primitives"),
    ("primitive-not-object", setter("meshes.0.primitives", [3]), r"primitive 0: is not an object"),
    (
        "attributes-not-object",
        setter(f"{PRIMITIVE}.attributes", [0]),
        r"primitive 0: 'attributes' must be an object",
    ),
    (
        "position-missing",
        setter(f"{PRIMITIVE}.attributes", {"NORMAL": 0}),
        r"primitive 0: has no POSITION attribute",
    ),
    ("accessors-missing", setter("accessors", ...), r"accessor 0 does not exist \(the file has 0\)"),
    ("accessors-not-list", setter("accessors", 4), r"'accessors' must be an array of objects"),
    ("accessor-not-object", setter("accessors.2", 7), r"'accessors' must be an array of objects"),
]:
    gltf_case(label, mutate, error, heavy=label in HEAVY)


def gltf_bytes_case(name: str, change: Callable[[bytearray], None], error: str) -> None:
    """A case from the valid document whose buffer bytes ``change`` edits (data written after)."""

    def build(folder: Path) -> tuple[Path, dict]:
        document, blob = gltf_document()
        data = bytearray(blob)
        change(data)
        return write_gltf(folder, document, bytes(data)), {}

    add(f"gltf/{name}", build, error)


gltf_bytes_case(
    "target-inf",
    lambda data: data.__setitem__(slice(72 + 24, 72 + 28), np.float32(np.inf).tobytes()),
    r"blendshape 'jawOpen' has a non-finite displacement at vertex 2",
)
gltf_bytes_case(
    "target-nan",
    lambda data: data.__setitem__(slice(144 + 48, 144 + 52), np.float32(np.nan).tobytes()),
    r"blendshape 'smile' has a non-finite displacement at vertex 4",
)
gltf_bytes_case(
    "index-huge",
    lambda data: data.__setitem__(slice(216, 220), np.uint32(2**32 - 1).tobytes()),
    r"index 4294967295 is past the 6 vertices",
)
gltf_bytes_case(
    "neutral-nan",
    lambda data: data.__setitem__(slice(0, 4), b"\xff\xff\xff\x7f"),
    r"face\.gltf: neutral has a non-finite coordinate at vertex 0",
)
gltf_bytes_case(
    "bin-truncated",
    lambda data: data.__delitem__(slice(200, None)),
    r"buffer 0 holds 200 bytes, fewer than its byteLength 264",
)

for label, text, error in [
    ("not-json", "{ not json", r"face\.gltf: not a readable glTF 2\.0 file \(JSONDecodeError"),
    ("top-level-array", "[1, 2, 3]", r"not a readable glTF 2\.0 file \(the JSON is not an object\)"),
    (
        "deep-nesting",
        '{"a": ' + "[" * 200_000 + "]" * 200_000 + "}",
        r"not a readable glTF 2\.0 file \(RecursionError",
    ),
    (
        "huge-int",
        '{"asset": {"version": "2.0"}, "x": ' + "9" * 100_000 + "}",
        r"not a readable glTF 2\.0 file",
    ),
    ("nan-literal", '{"asset": {"version": "2.0"}, "meshes": NaN}', r"'meshes' must be an array of objects"),
    ("empty", "", r"not a readable glTF 2\.0 file"),
    ("no-meshes-key", '{"asset": {"version": "2.0"}}', r"face\.gltf: has no meshes"),
]:
    add(f"gltf/json-{label}", lambda folder, text=text: (write_gltf(folder, {}, b"", text=text), {}), error)


@case("gltf/json-invalid-utf8", r"face\.gltf: not a readable glTF 2\.0 file")
def _invalid_utf8(folder: Path) -> tuple[Path, dict]:
    path = folder / "face.gltf"
    path.write_bytes(b'{"asset": {"version": "2.0\xff\xfe"}}')
    return path, {}


def top_level_gltf(kind: str) -> Callable[[Path], tuple[Path, dict]]:
    def build(folder: Path) -> tuple[Path, dict]:
        path = folder / "face.gltf"
        if kind == "fifo":
            os.mkfifo(path)
        elif kind == "dev-zero":
            path.symlink_to("/dev/zero")
        else:
            path.symlink_to(folder / "gone.gltf")
        return path, {}

    return build


add("gltf/file-fifo", top_level_gltf("fifo"), r"face\.gltf: is a FIFO \(named pipe\), not a regular file")
add(
    "gltf/file-dev-zero", top_level_gltf("dev-zero"), r"face\.gltf: is a character device, not a regular file"
)
add("gltf/file-dangling", top_level_gltf("dangling"), r"face\.gltf: symbolic link to .*gone\.gltf")


def sibling_primitive(change: Callable[[dict], None]) -> Callable[[dict, Path], None]:
    """A second primitive sharing the first one's accessors, changed by ``change``."""

    def mutate(document: dict, folder: Path) -> None:
        primitive = json.loads(json.dumps(document["meshes"][0]["primitives"][0]))
        change(primitive)
        document["meshes"][0]["primitives"].append(primitive)

    return mutate


gltf_case(
    "sibling-fewer-targets",
    sibling_primitive(lambda p: p["targets"].pop()),
    r"primitive 1: has 1 morph targets, primitive 0 has 2",
)
gltf_case(
    "sibling-no-targets",
    sibling_primitive(lambda p: p.pop("targets")),
    r"primitive 1: has 0 morph targets, primitive 0 has 2",
)
gltf_case(
    "sibling-other-names",
    sibling_primitive(lambda p: p.update(extras={"targetNames": ["x", "y"]})),
    r"primitive 1: its morph targets are named differently",
)
gltf_case(
    "sibling-lines",
    sibling_primitive(lambda p: p.update(mode=1)),
    warning=r"primitive 1: mode 1 \(LINES\) has no triangles; left out",
    check=lambda rig: rig.n_vertices == 6 and rig.provenance.primitives == (0,),
)
gltf_case(
    "second-mesh-with-targets",
    lambda document, folder: (
        document["meshes"].insert(0, json.loads(json.dumps(document["meshes"][0])) | {"name": "Teeth"})
        or document["meshes"][0]["primitives"][0]["targets"].pop()
    ),
    warning=r"only one mesh is read; left out: 'Teeth' \(1 morph target\)",
    check=lambda rig: rig.provenance.mesh == "Face" and rig.names == ("jawOpen", "smile"),
)

# == GLB containers ========================================================================================


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


# == native .npz ===========================================================================================
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

# == MakeHuman .target sets ================================================================================
BASE = obj_text()  # 16 vertices


def target_folder(folder: Path, targets: dict[str, str | bytes], *, base: str = BASE) -> Path:
    root = folder / "set"
    (root / "targets").mkdir(parents=True)
    (root / "base.obj").write_text(base)
    (root / "targets" / "ok.target").write_text("1 0 0 1\n")
    for name, content in targets.items():
        (root / "targets" / name).write_bytes(content if isinstance(content, bytes) else content.encode())
    return root


def target_case(name: str, content: str | bytes, error: str, file: str = "bad.target", **kwargs) -> None:
    add(f"target/{name}", lambda folder: (target_folder(folder, {file: content}), {}), error, **kwargs)


for label, content, error in [
    ("three-values", "3 0 1\n", r"bad\.target:1: expected 'vid dx dy dz', got '3 0 1'"),
    ("five-values", "3 0 1 0 9\n", r"bad\.target:1: expected 'vid dx dy dz'"),
    ("fractional-vid", "2.5 0 1 0\n", r"bad\.target:1: expected 'vid dx dy dz'"),
    ("letter", "3 0 x 0\n", r"bad\.target:1: expected 'vid dx dy dz', got '3 0 x 0'"),
    ("vid-past-base", "16 0 1 0\n", r"bad\.target:1: vertex 16 is outside the base mesh's 0\.\.15"),
    ("vid-negative", "-1 0 1 0\n", r"bad\.target:1: vertex -1 is outside the base mesh's 0\.\.15"),
    (
        "vid-past-64-bits",
        "99999999999999999999999 0 1 0\n",
        r"bad\.target:1: vertex 99999999999999999999999 is outside",
    ),
    ("nan", "3 0 nan 0\n", r"bad\.target:1: vertex 3 has a non-finite displacement"),
    ("inf", "3 inf 0 0\n", r"bad\.target:1: vertex 3 has a non-finite displacement"),
    ("overflowing-number", "3 1e999 0 0\n", r"bad\.target:1: vertex 3 has a non-finite displacement"),
    (
        "vertex-twice",
        "3 0 1 0\n4 0 1 0\n3 1 0 0\n",
        r"bad\.target:3: vertex 3 is listed twice \(also line 1\)",
    ),
    (
        "larger-than-base-allows",
        "# " + "x" * 200_000 + "\n",
        r"bad\.target: 195\.3 KiB, more than a target for 16 vertices can hold",
    ),
    (
        "binary-garbage",
        bytes(np.random.default_rng(2).integers(0, 256, 2048, dtype=np.uint8)),
        r"bad\.target:\d+: expected 'vid dx dy dz'",
    ),
    ("nul-bytes", "3 0\x001 0\n", r"bad\.target:1: expected 'vid dx dy dz'"),
]:
    target_case(label, content, error)

MEGA_BOMB = gzip.compress(b"\n" * 2**20, compresslevel=9)  # 1 KiB that inflates to 1 MiB


@case(
    "target/gz-bomb-900MB",
    r"bomb\.target\.gz: inflates past 689\.0 KiB, more than a target for 5000 vertices can hold",
    heavy=True,
)
def _gz_bomb(folder: Path) -> tuple[Path, dict]:
    # As a MakeHuman base: a target for 5,000 vertices needs at most 690 KiB; this 900 KiB file of 900
    # gzip members inflates to 900 MiB.
    grid = np.random.default_rng(4).random((5000, 3))
    root = target_folder(folder, {"bomb.target.gz": MEGA_BOMB * 900}, base=obj_text(grid, [[0, 1, 2]]))
    return root, {}


for label, content, error in [
    ("gz-bomb-one-member", gzip.compress(b"0" * 50 * 2**20), r"bad\.target\.gz: inflates past 66\.0 KiB"),
    ("gz-truncated", gzip.compress(b"1 0 0 1\n" * 50)[:-12], r"bad\.target\.gz: truncated gzip stream"),
    ("gz-not-gzip", b"1 0 0 1\n", r"bad\.target\.gz: not a valid gzip stream \(Error -3"),
    ("gz-empty", b"", r"bad\.target\.gz: empty file, not a gzip stream"),
    (
        "gz-trailing-garbage",
        gzip.compress(b"1 0 0 1\n") + b"junk",
        r"bad\.target\.gz: not a valid gzip stream",
    ),
    (
        "gz-crc-flip",
        gzip.compress(b"1 0 0 1\n")[:-8] + b"\0\0\0\0" + gzip.compress(b"1 0 0 1\n")[-4:],
        r"bad\.target\.gz: not a valid gzip stream \(Error -3 while decompressing data: "
        r"incorrect data check\)",
    ),
    ("gz-bad-line", gzip.compress(b"1 0 0\n"), r"bad\.target\.gz:1: expected 'vid dx dy dz', got '1 0 0'"),
]:
    target_case(label, content, error, file="bad.target.gz")


def target_entry(kind: str) -> Callable[[Path], tuple[Path, dict]]:
    def build(folder: Path) -> tuple[Path, dict]:
        root = target_folder(folder, {})
        entry = root / "targets" / "bad.target"
        outside = folder / "outside.target"
        outside.write_text("2 0 1 0\n")
        if kind == "fifo":
            os.mkfifo(entry)
        elif kind == "dangling":
            entry.symlink_to(root / "gone.target")
        elif kind == "loop":
            entry.symlink_to(entry)
        elif kind == "outside":
            entry.symlink_to(outside)
        elif kind == "dev-zero":
            entry.symlink_to("/dev/zero")
        elif kind == "folder":
            entry.mkdir()
        elif kind == "base-fifo":
            (root / "base.obj").unlink()
            os.mkfifo(root / "base.obj")
        return root, {}

    return build


for kind, error in [
    ("fifo", r"bad\.target: is a FIFO \(named pipe\), not a regular file"),
    ("dangling", r"bad\.target: symbolic link to '.*gone\.target', which does not exist"),
    ("loop", r"bad\.target: symbolic link loop"),
    ("outside", r"bad\.target: resolves to .*outside\.target, outside the rig's folder"),
    ("dev-zero", r"bad\.target: is a character device, not a regular file"),
    ("folder", r"bad\.target: is a folder, not a regular file"),
    ("base-fifo", r"base\.obj: is a FIFO \(named pipe\), not a regular file"),
]:
    add(f"target/entry-{kind}", target_entry(kind), error)


@case(
    "target/linked-subfolder",
    warning=r"targets/(more|self): symbolic link to a folder, not searched for rig files",
    check=lambda rig: rig.names == ("ok",),
)
def _linked_subfolder(folder: Path) -> tuple[Path, dict]:
    root = target_folder(folder, {})
    elsewhere = folder / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "hidden.target").write_text("2 0 1 0\n")
    (root / "targets" / "more").symlink_to(elsewhere)
    (root / "targets" / "self").symlink_to(root)  # a loop, were links followed
    return root, {}


@case(
    "target/two-bases",
    r"set: expected exactly one base \.obj beside the targets \(found: a\.obj, base\.obj\)",
)
def _two_bases(folder: Path) -> tuple[Path, dict]:
    root = target_folder(folder, {})
    (root / "a.obj").write_text(BASE)
    return root, {}


@case("target/duplicate-names", r"duplicate blendshape name 'ok'")
def _duplicate_targets(folder: Path) -> tuple[Path, dict]:
    root = target_folder(folder, {})
    (root / "targets" / "ok.target.gz").write_bytes(gzip.compress(b"2 0 1 0\n"))
    return root, {}


@case("target/many-empty-targets", r"set: 400 targets of 20000 vertices would take 183\.1 MiB, more than")
def _many_empty_targets(folder: Path) -> tuple[Path, dict]:
    # Empty target files cost nothing on disk but a dense delta each: enough of them over a large base
    # ask for gigabytes from a folder of a few hundred KB.
    vertices = np.random.default_rng(3).random((20_000, 3))
    root = folder / "set"
    (root / "targets").mkdir(parents=True)
    (root / "base.obj").write_text(obj_text(vertices, [[0, 1, 2]]))
    for i in range(400):
        (root / "targets" / f"t{i:05d}.target").write_text("")
    return root, {}


def manifest_target_case(name: str, manifest: object, error: str) -> None:
    def build(folder: Path) -> tuple[Path, dict]:
        root = target_folder(folder, {})
        (folder / "secret.target").write_text("2 0 1 0\n")
        path = root / "set.json"
        path.write_text(manifest if isinstance(manifest, str) else json.dumps(manifest))
        return path, {}

    add(f"target/manifest-{name}", build, error)


for label, manifest, error in [
    (
        "base-leaves-folder",
        {"base": "../base.obj", "targets": ["targets/ok.target"]},
        r"set\.json: '\.\./base\.obj' leaves the folder",
    ),
    (
        "base-absolute",
        {"base": "/etc/hostname", "targets": ["targets/ok.target"]},
        r"set\.json: '/etc/hostname' is an absolute path",
    ),
    (
        "base-number",
        {"base": 5, "targets": ["targets/ok.target"]},
        r"set\.json: a file name must be a non-empty string, got 5",
    ),
    (
        "target-leaves-folder",
        {"base": "base.obj", "targets": ["../../secret.target"]},
        r"set\.json: '\.\./\.\./secret\.target' leaves the folder",
    ),
    (
        "target-absolute",
        {"base": "base.obj", "targets": ["/etc/hostname"]},
        r"set\.json: '/etc/hostname' is an absolute path",
    ),
    (
        "target-number",
        {"base": "base.obj", "targets": [5]},
        r"set\.json: a file name must be a non-empty string, got 5",
    ),
    (
        "mapping-leaves-folder",
        {"base": "base.obj", "targets": {"x": "targets/../../secret.target"}},
        r"leaves the folder",
    ),
    (
        "glob-leaves-folder",
        {"base": "base.obj", "targets": "../*.target"},
        r"set\.json: '\.\./\*\.target' leaves the folder",
    ),
    ("glob-absolute", {"base": "base.obj", "targets": "/etc/*"}, r"set\.json: '/etc/\*' is an absolute path"),
    (
        "glob-matches-nothing",
        {"base": "base.obj", "targets": "nothing/*.target"},
        r"set\.json: no \.target files match",
    ),
    (
        "targets-number",
        {"base": "base.obj", "targets": 5},
        r"set\.json: 'targets' must be a glob, a list of files",
    ),
    (
        "crop-rings-string",
        {"base": "base.obj", "targets": ["targets/ok.target"], "crop_rings": "2"},
        r"set\.json: 'crop_rings' must be an integer, got '2'",
    ),
    (
        "units-number",
        {"base": "base.obj", "targets": ["targets/ok.target"], "units": 10},
        r"set\.json: 'units' must be a string, got 10",
    ),
    ("not-json", "{base: x}", r"set\.json: not a readable JSON manifest"),
    ("deep-nesting", "[" * 100_000 + "]" * 100_000, r"set\.json: not a readable JSON manifest"),
    ("missing-keys", {"base": "base.obj"}, r"set\.json: a target-set manifest needs 'base' and 'targets'"),
    (
        "target-missing",
        {"base": "base.obj", "targets": ["targets/gone.target"]},
        r"gone\.target: target listed in set\.json is missing",
    ),
]:
    manifest_target_case(label, manifest, error)


def target_zip(folder: Path, members: dict[str, bytes], *, method: int = zipfile.ZIP_DEFLATED) -> Path:
    path = folder / "set.zip"
    path.write_bytes(
        zip_bytes({"base.obj": BASE.encode(), "ok.target": b"1 0 0 1\n", **members}, method=method)
    )
    return path


def written(path: Path, data: bytes) -> Path:
    path.write_bytes(data)
    return path


def zip_case(name: str, make: Callable[[Path], Path], error: str, **kwargs) -> None:
    add(f"target/zip-{name}", lambda folder: (make(folder), {}), error, **kwargs)


zip_case(
    "gz-bomb-member",
    lambda f: target_zip(f, {"bad.target.gz": gzip.compress(b"0" * 50 * 2**20)}),
    r"set\.zip!bad\.target\.gz: inflates past 66\.0 KiB",
    heavy=True,
)
zip_case(
    "deflate-bomb-member",
    lambda f: target_zip(f, {"bad.target": b"\n" * 20 * 2**20}),
    r"set\.zip!bad\.target: 20\.0 MiB, more than a target for 16 vertices can hold",
    heavy=True,
)
zip_case(
    "base-bomb",
    lambda f: target_zip(f, {"base.obj": b"v 0 0 0\n" * (40 * 2**20 // 8)}),
    r"set\.zip!base\.obj: 40\.0 MiB, more than an OBJ deflated this small can hold",
    heavy=True,
)
zip_case(
    "bzip2-members",
    lambda f: target_zip(f, {}, method=zipfile.ZIP_BZIP2),
    r"set\.zip!base\.obj: compressed with zip method 12",
)
zip_case(
    "truncated",
    lambda f: written(f / "set.zip", target_zip(f, {}).read_bytes()[:120]),
    r"set\.zip: not a zip archive",
)
zip_case(
    "not-zip",
    lambda f: written(f / "set.zip", b"PK but not really"),
    r"set\.zip: not a zip archive",
)
zip_case(
    "bad-target-member",
    lambda f: target_zip(f, {"bad.target": b"1 x 0 1\n"}),
    r"set\.zip!bad\.target:1: expected 'vid dx dy dz'",
)


@case("target/zip-crc-flip", r"set\.zip!ok\.target: corrupt archive member \(Bad CRC-32")
def _zip_crc(folder: Path) -> tuple[Path, dict]:
    path = target_zip(folder, {}, method=zipfile.ZIP_STORED)
    data = bytearray(path.read_bytes())
    data[data.index(b"1 0 0 1\n")] = ord("2")
    path.write_bytes(bytes(data))
    return path, {}


@case("target/zip-fifo", r"set\.zip: is a FIFO \(named pipe\), not a regular file")
def _zip_fifo(folder: Path) -> tuple[Path, dict]:
    os.mkfifo(folder / "set.zip")
    return folder / "set.zip", {}


# == the checks ============================================================================================
@contextmanager
def guarded(*, trace: bool = True) -> Iterator[dict]:
    """Fail on a hang (the alarm raises in the test; faulthandler dumps every stack and exits if even
    that cannot interrupt), and report the peak of traced allocations in ``stats["peak"]``."""

    faulthandler.dump_traceback_later(3 * HANG_SECONDS, exit=True)
    if trace:
        tracemalloc.start()
    stats: dict = {}
    try:
        with hang_alarm(HANG_SECONDS):
            yield stats
    finally:
        if trace:
            stats["peak"] = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
        faulthandler.cancel_dump_traceback_later()


def test_the_corpus_is_large_and_its_names_unique() -> None:
    names = [case.name for case in CASES]
    assert len(names) == len(set(names))
    classes = {}
    for name in names:
        classes[name.split("/")[0]] = classes.get(name.split("/")[0], 0) + 1
    assert len(CASES) >= 150 and set(classes) == {"obj", "gltf", "glb", "npz", "target"}


@pytest.mark.parametrize("case", CASES, ids=lambda case: case.name)
def test_malformed_input_is_refused_naming_file_and_problem(case: Case, tmp_path: Path) -> None:
    path, options = case.build(tmp_path)
    if case.error is not None:
        with guarded() as stats, pytest.raises(RigError) as caught:
            rigs.load(path, **options)
        message = str(caught.value)
        assert "\n" not in message and (str(tmp_path) in message or str(path) in message)
        assert caught.match(case.error), message
    else:
        with guarded() as stats, pytest.warns(RigWarning, match=case.warning):
            rig = rigs.load(path, **options)
        assert case.check(rig), rig
    assert stats["peak"] < PEAK_BYTES, f"peak of {stats['peak'] / 2**20:.0f} MiB"


CHILD = """
import json, resource, sys
import rigs
from pathlib import Path
status = dict(line.split(":", 1) for line in open("/proc/self/status") if ":" in line)
base = int(status["VmSize"].split()[0]) * 1024
resource.setrlimit(resource.RLIMIT_AS, (base + 2**30, base + 2**30))
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
try:
    rigs.load(Path(sys.argv[1]), **json.loads(sys.argv[2]))
    outcome = "loaded"
except rigs.RigError as error:
    outcome = "RigError: " + str(error)
except BaseException as error:
    outcome = type(error).__name__ + ": " + str(error)[:300]
after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({"outcome": outcome, "rss": (after - before) * 1024}))
"""


@pytest.mark.parametrize("case", [case for case in CASES if case.heavy], ids=lambda case: case.name)
def test_inputs_that_would_take_gigabytes_stay_within_1_gib_of_address_space(
    case: Case, tmp_path: Path
) -> None:
    path, options = case.build(tmp_path)
    done = subprocess.run(
        [sys.executable, "-c", CHILD, str(path), json.dumps(options)],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result["outcome"].startswith("RigError: "), result["outcome"]
    assert result["rss"] < PEAK_BYTES


def test_an_8000_corner_concave_polygon_triangulates_without_hanging(tmp_path: Path) -> None:
    n = 8000
    angles = np.linspace(0, 2 * np.pi, n, endpoint=False)
    radii = np.where(np.arange(n) % 2 == 0, 1.0, 0.6)
    ring = np.stack([np.cos(angles) * radii, np.sin(angles) * radii, np.zeros(n)], axis=1)
    rig = tmp_path / "star"
    rig.mkdir()
    (rig / "neutral.obj").write_text(obj_text(ring, [list(range(n))]))
    (rig / "lift.obj").write_text(obj_text(ring + [0, 0, 0.1], [list(range(n))]))
    with guarded(trace=False):
        loaded = rigs.load(rig)
    normals = np.cross(
        *(loaded.neutral[loaded.triangles[:, i]] - loaded.neutral[loaded.triangles[:, 0]] for i in (1, 2))
    )
    assert loaded.n_triangles == n - 2 and (normals[:, 2] > 0).all()
    area = 0.5 * np.abs(
        np.dot(ring[:, 0], np.roll(ring[:, 1], -1)) - np.dot(ring[:, 1], np.roll(ring[:, 0], -1))
    )
    assert 0.5 * normals[:, 2].sum() == pytest.approx(area)
