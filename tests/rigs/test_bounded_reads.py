"""Side files a rig is used with (regions, manifests) are read bounded: a regular file, a size cap before
reading, and a depth no parser recursion can overflow; each refusal is one line naming the file."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

import rigs
from rigs._safe import read_json


def _fifo(tmp_path: Path) -> Path:
    path = tmp_path / "regions.json"
    os.mkfifo(path)
    return path


def _deep(tmp_path: Path) -> Path:
    path = tmp_path / "regions.json"
    path.write_text("[" * 100_000 + "]" * 100_000)
    return path


def _large(tmp_path: Path) -> Path:
    path = tmp_path / "regions.json"
    with path.open("wb") as stream:
        stream.truncate(300 * 2**20)  # sparse: costs no disk
    return path


CASES = {
    "device": (lambda tmp_path: Path("/dev/zero"), "is a character device, not a regular file"),
    "fifo": (_fifo, "is a FIFO"),
    "deep-json": (_deep, "not a readable JSON regions file \\(nested too deeply\\)"),
    "too-large": (_large, "larger than 256 MiB"),
    "not-utf8": (lambda tmp_path: _write(tmp_path, b'{"a": "\xff"}'), "not UTF-8"),
    "missing": (lambda tmp_path: tmp_path / "nothing.json", "no such file"),
}


def _write(tmp_path: Path, data: bytes) -> Path:
    path = tmp_path / "regions.json"
    path.write_bytes(data)
    return path


@pytest.mark.parametrize("case", sorted(CASES))
def test_a_hostile_regions_file_is_one_line_naming_it(case: str, tmp_path: Path) -> None:
    make, message = CASES[case]
    path = make(tmp_path)
    with pytest.raises(rigs.RigError, match=message) as caught:
        rigs.read_regions(path, 4)
    assert str(path) in str(caught.value) and "\n" not in str(caught.value)


def test_read_json_caps_before_reading(tmp_path: Path) -> None:
    path = _write(tmp_path, b"[" + b"0," * 1000 + b"0]")
    assert len(read_json(path, limit=4096, what="list")) == 1001
    with pytest.raises(rigs.RigError, match="more than a list can hold"):
        read_json(path, limit=100, what="list")


@pytest.mark.parametrize("case", ["device", "fifo", "deep-json", "not-utf8"])
def test_a_hostile_constraints_file_is_one_line_naming_it(case: str, tmp_path: Path) -> None:
    import packing

    make, message = CASES[case]
    path = make(tmp_path)
    with pytest.raises(ValueError, match=message.replace("regions file", "constraints file")) as caught:
        packing.read_constraints(path)
    assert str(path) in str(caught.value) and "\n" not in str(caught.value)


@pytest.mark.parametrize(
    ("name", "relative"),
    [
        ("face.mtl", "face.mtl"),
        ("maps\\skin.png", "maps/skin.png"),
        ("./maps/../skin.png", None),
        ("../shared/face.mtl", None),
        ("/etc/passwd", None),
        ("C:\\rigs\\face.mtl", None),
        ("\\\\server\\share\\face.mtl", None),
        (".", None),
    ],
)
def test_a_reference_outside_the_folder_is_told_apart(name, relative):
    """The one test of a file reference written inside a rig's file (an OBJ's ``mtllib``, a library's maps):
    what a copy of the rig's folder would carry along."""
    assert rigs.folder_relative(name) == relative
