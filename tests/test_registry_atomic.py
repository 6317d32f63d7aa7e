"""`registry.atomic_write`: the one writer behind every file the project writes."""

from __future__ import annotations

import os

import numpy as np
import pytest

from registry import append_text, atomic_path, atomic_write, move_apart


def test_text_bytes_and_a_streaming_writer_all_land_whole(tmp_path):
    assert atomic_write(tmp_path / "a.txt", "héllo").read_text(encoding="utf-8") == "héllo"
    assert atomic_write(tmp_path / "b.bin", b"\x00\x01").read_bytes() == b"\x00\x01"
    path = atomic_write(tmp_path / "c.npz", lambda stream: np.savez_compressed(stream, x=np.arange(3)))
    assert np.load(path)["x"].tolist() == [0, 1, 2]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt", "b.bin", "c.npz"]  # no temporary left


def test_a_replaced_file_keeps_its_permissions(tmp_path):
    path = tmp_path / "kept.txt"
    path.write_text("old")
    os.chmod(path, 0o600)
    atomic_write(path, "new")
    assert path.read_text() == "new" and path.stat().st_mode & 0o777 == 0o600


def test_a_failing_writer_leaves_the_old_content_and_no_temporary(tmp_path):
    path = tmp_path / "old.txt"
    path.write_text("old")

    def half_then_fail(stream):
        stream.write(b"half")
        raise OSError(28, "No space left on device")

    with pytest.raises(OSError, match="No space left"):
        atomic_write(path, half_then_fail)
    assert path.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["old.txt"]


def test_a_library_that_writes_to_a_path_writes_the_temporary_file_then_it_lands(tmp_path):
    path = tmp_path / "face.usda"
    with atomic_path(path) as temporary:
        assert temporary.parent == tmp_path and temporary.name.startswith(".face.usda.")
        temporary.write_text("#usda 1.0\n")
        assert not path.exists()
    assert path.read_text() == "#usda 1.0\n" and [p.name for p in tmp_path.iterdir()] == ["face.usda"]
    with pytest.raises(RuntimeError), atomic_path(path) as temporary:
        temporary.write_text("half")
        raise RuntimeError("the library failed")
    assert path.read_text() == "#usda 1.0\n" and [p.name for p in tmp_path.iterdir()] == ["face.usda"]


def test_appended_lines_follow_each_other(tmp_path):
    path = tmp_path / "log.jsonl"
    append_text(path, "one\n")
    append_text(path, "two\n")
    assert path.read_text() == "one\ntwo\n"


def test_a_file_moved_apart_never_lands_over_another(tmp_path):
    aside = tmp_path / "broken"
    for content in ("first", "second", "third"):
        (tmp_path / "part.parquet").write_text(content)
        move_apart(tmp_path / "part.parquet", aside)
    moved = {path.name: path.read_text() for path in aside.iterdir()}
    assert moved == {"part.parquet": "first", "part.parquet.1": "second", "part.parquet.2": "third"}
