"""Output folders (`harness._outdir`): only files the harness wrote are ever replaced or removed."""

from __future__ import annotations

import errno
import json
import os
import tempfile
import time
import warnings
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from harness import _outdir as outdir
from harness._outdir import (
    MANIFEST_NAME,
    ChangedFileWarning,
    OutputFolder,
    OutputFolderError,
    atomic_write,
    claim,
    file_sha256,
)
from registry import StagedFile
from registry import _atomic as atomic


def test_a_new_folder_is_claimed_and_its_files_listed_with_kind_and_hash(tmp_path) -> None:
    folder = claim(tmp_path / "out" / "deep", kind="pack", force=False)
    path = folder.write_file("expressions.json", "{}\n")
    folder.write_file("meshes/expression_01.obj", b"v 0 0 0\n")
    manifest = json.loads((tmp_path / "out" / "deep" / MANIFEST_NAME).read_text())
    assert manifest["files"] == {
        "expressions.json": {"kind": "pack", "sha256": file_sha256(path)},
        "meshes/expression_01.obj": {
            "kind": "pack",
            "sha256": file_sha256(folder.path / "meshes/expression_01.obj"),
        },
    }
    assert path.read_text() == "{}\n"


def test_a_session_needs_force_to_be_replaced_and_replacing_removes_only_its_leftovers(tmp_path) -> None:
    out = tmp_path / "out"
    first = claim(out, kind="pack", force=False)
    for index in range(1, 4):
        first.write_file(f"expression_0{index}.obj", f"expression {index}\n")
    with pytest.raises(OutputFolderError, match=r"holds a harness pack .*use --force to replace it") as error:
        claim(out, kind="pack", force=False)
    assert str(out) in str(error.value) and "\n" not in str(error.value)
    (out / "expression_04.obj").write_text("the user's own\n")
    second = claim(out, kind="pack", force=True)
    second.write_file("expression_01.obj", "shorter packing\n")
    removed = second.remove_stale(keep=["expression_01.obj"])
    assert sorted(path.name for path in removed) == ["expression_02.obj", "expression_03.obj"]
    assert sorted(path.name for path in out.iterdir()) == [
        MANIFEST_NAME,
        "expression_01.obj",
        "expression_04.obj",
    ]
    assert (out / "expression_01.obj").read_text() == "shorter packing\n"


def test_a_folder_with_files_not_written_by_harness_is_refused_and_with_force_kept(tmp_path) -> None:
    out = tmp_path / "scans"
    out.mkdir()
    (out / "expression_01.obj").write_text("the user's scan\n")
    (out / "expression_09.obj").write_text("another\n")
    with pytest.raises(OutputFolderError, match="is not empty and holds no harness output; .*--force"):
        claim(out, kind="pack", force=False)
    folder = claim(out, kind="pack", force=True)
    with pytest.raises(OutputFolderError, match=r"expression_01.obj: exists and was not written by harness"):
        folder.write_file("expression_01.obj", "ours\n")
    with pytest.raises(OutputFolderError, match="expression_01.obj"):
        folder.check_free(["expression_02.obj", "expression_01.obj"])
    folder.write_file("expressions.json", "{}\n")
    assert folder.remove_stale(keep=()) == [out / "expressions.json"]
    assert (out / "expression_01.obj").read_text() == "the user's scan\n"
    assert (out / "expression_09.obj").read_text() == "another\n"


@pytest.mark.parametrize("where", ["is", "inside", "contains"])
@pytest.mark.parametrize("force", [False, True])
def test_the_input_is_never_the_output(tmp_path, where: str, force: bool) -> None:
    rig = tmp_path / "face"
    rig.mkdir()
    (rig / "neutral.obj").write_text("v 0 0 0\n")
    folder = {"is": rig, "inside": rig / "packed", "contains": tmp_path}[where]
    relation = {"is": "is", "inside": "lies inside", "contains": "contains"}[where]
    with pytest.raises(OutputFolderError, match=f"{relation} the input .*choose an output folder apart"):
        claim(folder, kind="pack", force=force, protect=[rig])
    assert sorted(path.name for path in rig.iterdir()) == ["neutral.obj"]
    linked = tmp_path / "link"
    linked.symlink_to(rig)
    with pytest.raises(OutputFolderError, match="the input"):
        claim(linked, kind="pack", force=force, protect=[rig / "neutral.obj"])


def test_a_changed_file_is_left_in_place_with_a_warning_and_never_overwritten(tmp_path) -> None:
    folder = claim(tmp_path / "out", kind="pack", force=False)
    folder.write_file("expression_01.obj", "ours\n")
    folder.write_file("expression_02.obj", "ours too\n")
    (tmp_path / "out" / "expression_01.obj").write_text("edited by the artist\n")
    again = claim(tmp_path / "out", kind="pack", force=True)
    with pytest.raises(OutputFolderError, match="or was changed since"):
        again.write_file("expression_01.obj", "new\n")
    with pytest.warns(ChangedFileWarning, match="expression_01.obj: changed since harness pack wrote it"):
        removed = again.remove_stale(keep=())
    assert [path.name for path in removed] == ["expression_02.obj"]
    assert (tmp_path / "out" / "expression_01.obj").read_text() == "edited by the artist\n"
    assert "expression_01.obj" not in json.loads((tmp_path / "out" / MANIFEST_NAME).read_text())["files"]


def test_sessions_of_other_kinds_share_a_folder_and_are_never_removed(tmp_path) -> None:
    out = tmp_path / "out"
    claim(out, kind="run", force=False).write_file("records/part-0001.parquet", b"PAR1")
    pack = claim(out, kind="pack", force=False)  # no pack session here yet
    pack.write_file("expressions.json", "{}\n")
    again = claim(out, kind="pack", force=True)
    again.remove_stale(keep=())
    assert (out / "records/part-0001.parquet").read_bytes() == b"PAR1"
    with pytest.raises(OutputFolderError, match="holds a harness run"):
        claim(out, kind="run", force=False)


@pytest.mark.parametrize(
    "files",
    [
        {"../victim.txt": {"kind": "pack", "sha256": "0"}},
        {"/etc/passwd": {"kind": "pack", "sha256": "0"}},
        [],
    ],
)
def test_a_manifest_naming_files_outside_the_folder_is_not_ours(tmp_path, files) -> None:
    victim = tmp_path / "victim.txt"
    victim.write_text("keep me\n")
    out = tmp_path / "out"
    out.mkdir()
    (out / MANIFEST_NAME).write_text(
        json.dumps({"format": "harness-output-folder", "version": 1, "files": files})
    )
    with pytest.raises(OutputFolderError, match=f"{MANIFEST_NAME} is not a harness manifest"):
        claim(out, kind="pack", force=False)
    claim(out, kind="pack", force=True).remove_stale(keep=())
    assert victim.read_text() == "keep me\n"


def test_a_linked_subfolder_never_leads_a_write_or_a_removal_out_of_the_folder(tmp_path) -> None:
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    out = tmp_path / "out"
    folder = claim(out, kind="run", force=False)
    folder.write_file("records/part.parquet", b"ours")
    (outside / "part.parquet").write_bytes(b"ours")  # same content as the listed file
    (out / "records" / "part.parquet").unlink()
    (out / "records").rmdir()
    (out / "records").symlink_to(outside)
    again = claim(out, kind="run", force=True)
    with pytest.warns(ChangedFileWarning, match="part.parquet: linked; left in place"):
        assert again.remove_stale(keep=()) == []
    assert (outside / "part.parquet").read_bytes() == b"ours"
    with pytest.raises(OutputFolderError, match="links out of"):
        again.write_file("records/new.parquet", b"x")
    assert sorted(path.name for path in outside.iterdir()) == ["part.parquet"]


def test_a_failed_write_keeps_the_old_content_and_leaves_no_temporary_file(tmp_path, monkeypatch) -> None:
    folder = claim(tmp_path / "out", kind="pack", force=False)
    folder.write_file("expressions.json", "old\n")

    def disk_full(descriptor: int) -> None:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "fsync", disk_full)
    with pytest.raises(
        OutputFolderError, match="expressions.json: cannot write .No space left on device"
    ) as error:  # (the file is written aside before the manifest lists it)
        folder.write_file("expressions.json", "new\n")
    assert "\n" not in str(error.value)
    assert (tmp_path / "out" / "expressions.json").read_text() == "old\n"
    assert sorted(path.name for path in (tmp_path / "out").iterdir()) == [MANIFEST_NAME, "expressions.json"]


def test_atomic_writes_use_unique_temporary_names_and_normal_permissions(tmp_path) -> None:
    names = []
    original = tempfile.mkstemp

    def spy(*args, **kwargs):
        descriptor, name = original(*args, **kwargs)
        names.append(name)
        return descriptor, name

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(tempfile, "mkstemp", spy)
        for _ in range(3):
            atomic_write(tmp_path / "a.txt", "x")
    assert len(set(names)) == 3 and all(Path(name).parent == tmp_path for name in names)
    reference = tmp_path / "plain.txt"
    reference.write_text("x")
    assert (tmp_path / "a.txt").stat().st_mode == reference.stat().st_mode


@pytest.mark.parametrize("name", ["../x", "/abs", "a/../b", "", MANIFEST_NAME, "a//b", "a\\b"])
def test_names_outside_the_folder_are_refused(tmp_path, name: str) -> None:
    folder = claim(tmp_path / "out", kind="pack", force=False)
    with pytest.raises(OutputFolderError, match="is not a file name inside the output folder"):
        folder.write_file(name, "x")


NAMES = st.sampled_from([f"expression_{i:02d}.obj" for i in range(1, 7)] + ["expressions.json", "sub/a.txt"])


@settings(max_examples=60, deadline=None)
@given(
    user=st.dictionaries(NAMES, st.binary(max_size=8), max_size=4),
    first=st.lists(NAMES, max_size=6, unique=True),
    edited=st.sets(NAMES, max_size=3),
    second=st.lists(NAMES, max_size=6, unique=True),
)
def test_no_sequence_of_sessions_touches_a_file_harness_did_not_write(user, first, edited, second) -> None:
    with tempfile.TemporaryDirectory() as root:
        out = Path(root) / "out"
        for name, data in user.items():
            (out / name).parent.mkdir(parents=True, exist_ok=True)
            (out / name).write_bytes(data)
        folder = claim(out, kind="pack", force=True)
        ours = [name for name in first if name not in user]
        for name in ours:
            folder.write_file(name, f"first {name}".encode())
        edits = {name: b"edited " + name.encode() for name in edited if name in ours}
        for name, data in edits.items():
            (out / name).write_bytes(data)
        again = claim(out, kind="pack", force=True)
        written = []
        for name in second:
            try:
                again.write_file(name, f"second {name}".encode())
                written.append(name)
            except OutputFolderError:
                assert name in user or name in edits
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ChangedFileWarning)
            removed = {path.relative_to(out).as_posix() for path in again.remove_stale(keep=written)}
        for name, data in {**user, **edits}.items():
            assert (out / name).read_bytes() == data
        assert removed == set(ours) - set(edits) - set(written)
        for name in written:
            assert (out / name).read_bytes() == f"second {name}".encode()
        listed = json.loads((out / MANIFEST_NAME).read_text())["files"]
        assert set(listed) == set(written)


def _listed(out: Path) -> dict[str, dict[str, str]]:
    return json.loads((out / MANIFEST_NAME).read_text())["files"]


NAMES = ("b.obj", "sub/c.obj", "a.obj")


def test_several_files_are_listed_before_they_are_written_and_the_manifest_is_saved_once(
    tmp_path, monkeypatch
) -> None:
    out = tmp_path / "out"
    folder = claim(out, kind="pack", force=False)
    saved: list[dict[str, dict[str, str]]] = []
    original_save = OutputFolder.save

    def save(self: OutputFolder) -> Path:
        assert not any((out / name).exists() for name in NAMES)  # listed first, then written
        saved.append(dict(self.files))
        return original_save(self)

    monkeypatch.setattr(OutputFolder, "save", save)
    paths = folder.write_files(dict(zip(NAMES, ("b\n", b"c\n", "a\n"), strict=True)))
    assert paths == [out / "b.obj", out / "sub" / "c.obj", out / "a.obj"]
    assert len(saved) == 1 and sorted(saved[0]) == sorted(NAMES)
    assert all(folder.owns(name) for name in NAMES)
    assert _listed(out) == folder.files


def test_when_one_file_cannot_be_written_none_is_and_the_folder_is_as_it_was(tmp_path, monkeypatch) -> None:
    out = tmp_path / "out"
    folder = claim(out, kind="pack", force=False)
    folder.write_files({"first.obj": "old first\n", "second.obj": "old second\n"})
    before, listed = dict(folder.files), _listed(out)
    original_stage = outdir.stage

    def fail_on_the_second_file(path: Path, payload: bytes) -> StagedFile:
        if path.name in ("second.obj", "fourth.obj"):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return original_stage(path, payload)

    monkeypatch.setattr(outdir, "stage", fail_on_the_second_file)
    new = {"first.obj": "new first\n", "second.obj": "new second\n", "third.obj": "3\n", "fourth.obj": "4\n"}
    with pytest.raises(OutputFolderError, match="second.obj: cannot write"):  # (the first failure in order)
        folder.write_files(new)
    kept = [(out / name).read_text() for name in ("first.obj", "second.obj")]
    assert kept == ["old first\n", "old second\n"]
    assert folder.files == before and _listed(out) == listed
    assert sorted(path.name for path in out.iterdir()) == [MANIFEST_NAME, "first.obj", "second.obj"]


def test_files_are_put_in_place_only_after_the_manifest_lists_them(tmp_path, monkeypatch) -> None:
    out = tmp_path / "out"
    folder = claim(out, kind="pack", force=False)
    folder.write_file("a.obj", "old\n")
    original_save = OutputFolder.save

    def full_disk_at_the_manifest(self: OutputFolder) -> Path:
        assert (out / "a.obj").read_text() == "old\n" and not (out / "b.obj").exists()
        raise OutputFolderError(f"{self.manifest}: cannot write (No space left on device)")

    monkeypatch.setattr(OutputFolder, "save", full_disk_at_the_manifest)
    with pytest.raises(OutputFolderError, match="cannot write"):
        folder.write_files({"a.obj": "new\n", "b.obj": "b\n"})
    monkeypatch.setattr(OutputFolder, "save", original_save)
    assert (out / "a.obj").read_text() == "old\n" and folder.owns("a.obj") and "b.obj" not in folder.files
    assert sorted(path.name for path in out.iterdir()) == [MANIFEST_NAME, "a.obj"]  # (nothing staged is left)


def test_contents_that_fail_while_being_made_leave_nothing_behind(tmp_path) -> None:
    out = tmp_path / "out"
    folder = claim(out, kind="pack", force=False)

    def contents():
        yield "a.obj", "a\n"
        yield "sub/b.obj", "b\n"
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        folder.write_files(contents())
    assert folder.files == {} and [path.name for path in out.rglob("*") if path.is_file()] == []
    with pytest.raises(OutputFolderError, match="given twice"):
        folder.write_files([("a.obj", "a\n"), ("a.obj", "again\n")])
    assert [path.name for path in out.rglob("*") if path.is_file()] == []


def test_several_files_sync_their_folders_once_each(tmp_path, monkeypatch) -> None:
    folder = claim(tmp_path / "out", kind="pack", force=False)
    synced: list[Path] = []
    monkeypatch.setattr(atomic, "_sync_folder", synced.append)
    folder.write_files({"a.obj": "a\n", "b.obj": "b\n", "sub/c.obj": "c\n", "sub/d.obj": "d\n"})
    # the manifest's save, then the two folders of the four files once each
    assert synced == [folder.path, folder.path, folder.path / "sub"]


def test_contents_that_come_one_by_one_are_written_as_they_come(tmp_path, monkeypatch) -> None:
    folder = claim(tmp_path / "out", kind="pack", force=False)
    written: list[str] = []
    original_stage = outdir.stage

    def recording(path: Path, payload: bytes) -> StagedFile:
        time.sleep(0.01)  # (a slow disk: contents would otherwise come far ahead of the writes)
        written.append(path.name)
        return original_stage(path, payload)

    def contents():
        for index in range(20):
            # the file IN_FLIGHT places back is written before the next is made
            assert index <= outdir.IN_FLIGHT or f"{index - outdir.IN_FLIGHT - 1}.obj" in written
            yield f"{index}.obj", f"{index}\n"

    monkeypatch.setattr(outdir, "stage", recording)
    paths = folder.write_files(contents())
    assert [path.name for path in paths] == [f"{index}.obj" for index in range(20)]
    assert all(folder.owns(f"{index}.obj") for index in range(20))


def _interrupt_at(point: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Ctrl-C at ``point`` of a write: the manifest's folder sync (after the manifest is replaced), the
    second rename of a file just after it happened, or just before it."""
    calls: list[str] = []
    original_replace, original_sync = os.replace, atomic._sync_folder

    def replace(source, target) -> None:
        if Path(target).name == MANIFEST_NAME:
            return original_replace(source, target)
        calls.append(str(target))
        if point == "before a rename" and len(calls) == 2:
            raise KeyboardInterrupt
        original_replace(source, target)
        if point == "after a rename" and len(calls) == 2:
            raise KeyboardInterrupt

    def sync(folder: Path) -> None:
        if point == "in the manifest's save" and not calls:
            calls.append("sync")
            raise KeyboardInterrupt
        original_sync(folder)

    monkeypatch.setattr(os, "replace", replace)
    monkeypatch.setattr(atomic, "_sync_folder", sync)


@pytest.mark.parametrize("point", ["in the manifest's save", "after a rename", "before a rename"])
def test_an_interrupted_write_leaves_every_listed_file_as_listed(tmp_path, monkeypatch, point) -> None:
    out = tmp_path / "out"
    folder = claim(out, kind="pack", force=False)
    folder.write_files({"a.obj": "old a\n", "b.obj": "old b\n"})
    _interrupt_at(point, monkeypatch)
    with pytest.raises(KeyboardInterrupt):
        folder.write_files({"a.obj": "new a\n", "b.obj": "new b\n", "sub/c.obj": "c\n"})
    monkeypatch.undo()
    again = claim(out, kind="pack", force=True)
    assert all(again.owns(name) for name in _listed(out))  # what the manifest claims is on disk
    assert not [path for path in out.rglob("*") if path.name.endswith(".tmp")]
    assert not (out / "sub").exists() or (out / "sub" / "c.obj").exists()
    again.write_files({"a.obj": "x\n", "b.obj": "y\n", "sub/c.obj": "z\n"})  # (a --force rerun works)


def test_a_file_made_at_a_name_while_the_contents_are_made_is_not_replaced(tmp_path) -> None:
    out = tmp_path / "out"
    folder = claim(out, kind="pack", force=False)

    def contents():
        yield "mine.obj", "harness\n"
        (out / "mine.obj").write_text("the user's file\n")
        yield "other.obj", "harness\n"

    with pytest.raises(OutputFolderError, match="mine.obj: exists and was not written by harness pack"):
        folder.write_files(contents())
    assert (out / "mine.obj").read_text() == "the user's file\n"
    assert sorted(path.name for path in out.iterdir()) == ["mine.obj"] and folder.files == {}


def test_a_failed_file_stops_the_contents_and_its_folders_are_removed(tmp_path, monkeypatch) -> None:
    out = tmp_path / "out"
    folder = claim(out, kind="pack", force=False)
    made: list[int] = []

    def full_disk(path: Path, payload: bytes) -> StagedFile:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    def contents():
        for index in range(30):
            made.append(index)
            yield f"deep/er/{index}.obj", f"{index}\n"

    monkeypatch.setattr(outdir, "stage", full_disk)
    with pytest.raises(OutputFolderError, match=r"deep/er/0\.obj: cannot write .No space left on device"):
        folder.write_files(contents())
    assert len(made) <= outdir.IN_FLIGHT + 1  # (not every content was made)
    assert list(out.iterdir()) == [] and folder.files == {}


def test_a_name_cannot_be_both_a_file_and_a_folder_in_one_write(tmp_path) -> None:
    folder = claim(tmp_path / "out", kind="pack", force=False)
    for names in (["d/e.obj", "d"], ["d", "d/e.obj"]):
        with pytest.raises(OutputFolderError, match="both a file and a folder"):
            folder.write_files([(name, "x\n") for name in names])
        assert list((tmp_path / "out").iterdir()) == []
