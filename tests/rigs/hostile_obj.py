"""Hostile-input corpus (`tests/rigs/test_hostile_inputs.py`): OBJ folders."""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from pathlib import Path

import numpy as np

import rigs
from tests.rigs.hostile_corpus import add, case
from tests.rigs.rig_files import GRID, QUADS


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
