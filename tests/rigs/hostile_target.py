"""Hostile-input corpus (`tests/rigs/test_hostile_inputs.py`): MakeHuman .target sets."""

from __future__ import annotations

import gzip
import json
import os
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np

from tests.rigs.hostile_corpus import add, case
from tests.rigs.hostile_npz import zip_bytes
from tests.rigs.hostile_obj import obj_text

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
