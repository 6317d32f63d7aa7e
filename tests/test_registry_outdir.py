"""Output folders (`registry.claim`): only files the project wrote are ever replaced or removed, and an
output written as a whole lands at once or not at all."""

from __future__ import annotations

import errno
import json
import os
import tempfile
from pathlib import Path

import pytest
from hypothesis import given, settings, strategies as st

from registry import OutputFolderError, _atomic as atomic, _outdir as outdir, atomic_write, claim
from registry._outdir import MANIFEST_NAME, file_sha256


def _listed(out: Path) -> dict[str, dict[str, str]]:
    return json.loads((out / MANIFEST_NAME).read_text())["files"]


def _siblings(out: Path) -> list[str]:
    """What lies beside ``out`` named for it (unfinished replacements)."""
    return sorted(path.name for path in out.parent.iterdir() if path.name.startswith(f".{out.name}."))


def test_a_new_folder_is_claimed_and_its_files_listed_with_kind_and_hash(tmp_path) -> None:
    folder = claim(tmp_path / "out" / "deep", kind="pack", force=False)
    path, mesh = folder.replace({"expressions.json": "{}\n", "meshes/expression_01.obj": b"v 0 0 0\n"})
    manifest = json.loads((tmp_path / "out" / "deep" / MANIFEST_NAME).read_text())
    assert manifest["files"] == {
        "expressions.json": {"kind": "pack", "sha256": file_sha256(path), "inode": path.stat().st_ino},
        "meshes/expression_01.obj": {
            "kind": "pack",
            "sha256": file_sha256(mesh),
            "inode": mesh.stat().st_ino,
        },
    }
    assert path.read_text() == "{}\n" and folder.files == manifest["files"]
    assert _siblings(tmp_path / "out" / "deep") == []


def test_a_session_needs_force_to_be_replaced_and_replacing_leaves_only_the_new_one(tmp_path) -> None:
    out = tmp_path / "out"
    claim(out, kind="pack", force=False).replace(
        {f"expression_0{i}.obj": f"expression {i}\n" for i in (1, 2, 3)}
    )
    with pytest.raises(OutputFolderError, match=r"holds a harness pack .*use --force to replace it") as error:
        claim(out, kind="pack", force=False)
    assert str(out) in str(error.value) and "\n" not in str(error.value)
    (out / "expression_04.obj").write_text("the user's own\n")
    with pytest.raises(OutputFolderError, match=r"did not write or that changed since \(expression_04.obj\)"):
        claim(out, kind="pack", force=True)
    assert (out / "expression_04.obj").read_text() == "the user's own\n"
    (out / "expression_04.obj").unlink()
    claim(out, kind="pack", force=True).replace({"expression_01.obj": "shorter packing\n"})
    assert sorted(path.name for path in out.iterdir()) == [MANIFEST_NAME, "expression_01.obj"]
    assert (out / "expression_01.obj").read_text() == "shorter packing\n" and _siblings(out) == []


@pytest.mark.parametrize("force", [False, True])
def test_a_folder_with_files_not_written_by_harness_is_refused_and_kept(tmp_path, force: bool) -> None:
    out = tmp_path / "scans"
    out.mkdir()
    (out / "expression_01.obj").write_text("the user's scan\n")
    (out / "expression_09.obj").write_text("another\n")
    with pytest.raises(OutputFolderError, match=r"is not empty and holds no harness output \(expression_01"):
        claim(out, kind="pack", force=force)
    assert (out / "expression_01.obj").read_text() == "the user's scan\n"
    assert (out / "expression_09.obj").read_text() == "another\n"
    (out / "drafts").mkdir()  # (an empty folder is the user's too)
    for name in ("expression_01.obj", "expression_09.obj"):
        (out / name).unlink()
    with pytest.raises(OutputFolderError, match=r"holds no harness output \(drafts/\)"):
        claim(out, kind="pack", force=force)


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


def test_a_changed_file_is_refused_and_never_overwritten(tmp_path) -> None:
    out = tmp_path / "out"
    claim(out, kind="pack", force=False).replace(
        {"expression_01.obj": "ours\n", "expression_02.obj": "ours\n"}
    )
    (out / "expression_01.obj").write_text("edited by the artist\n")
    with pytest.raises(OutputFolderError, match=r"or that changed since \(expression_01.obj\)"):
        claim(out, kind="pack", force=True)
    assert (out / "expression_01.obj").read_text() == "edited by the artist\n"
    assert (out / "expression_02.obj").read_text() == "ours\n"


def test_outputs_of_other_kinds_are_never_replaced_and_a_nested_report_is_no_foreign_file(tmp_path) -> None:
    out = tmp_path / "out"
    run = claim(out, kind="run", force=False)
    atomic_write(out / "run.json", "{}\n")
    run.record("run.json")
    run.save()
    with pytest.raises(OutputFolderError, match=r"harness pack did not write .*\(run.json\)"):
        claim(out, kind="pack", force=True)
    claim(out / "report", kind="report", force=False).replace({"index.html": "<html>\n"})
    again = claim(out, kind="run", force=True)  # (the report is the report's own output)
    assert again.clear() == [out / "run.json"]
    assert (out / "report" / "index.html").read_text() == "<html>\n"
    (out / "report" / "index.html").write_text("edited\n")
    with pytest.raises(OutputFolderError, match=r"changed since \(report/index.html\)"):
        claim(out, kind="run", force=True)


@pytest.mark.parametrize(
    "files",
    [
        {"../victim.txt": {"kind": "pack", "sha256": "0"}},
        {"/etc/passwd": {"kind": "pack", "sha256": "0"}},
        [],
    ],
)
@pytest.mark.parametrize("force", [False, True])
def test_a_manifest_naming_files_outside_the_folder_is_not_ours(tmp_path, files, force: bool) -> None:
    victim = tmp_path / "victim.txt"
    victim.write_text("keep me\n")
    out = tmp_path / "out"
    out.mkdir()
    (out / MANIFEST_NAME).write_text(
        json.dumps({"format": "harness-output-folder", "version": 1, "files": files})
    )
    with pytest.raises(OutputFolderError, match=f"{MANIFEST_NAME} is not a harness manifest"):
        claim(out, kind="pack", force=force)
    assert victim.read_text() == "keep me\n" and (out / MANIFEST_NAME).exists()


@pytest.mark.parametrize("version", [1, 2])
@pytest.mark.parametrize("force", [False, True])
def test_a_forged_manifest_with_the_right_hash_never_makes_a_users_file_ours(
    tmp_path, version: int, force: bool
) -> None:
    out = tmp_path / "out"
    claim(out, kind="pack", force=False).replace({"expression_01.obj": "ours\n"})
    notes = out / "notes.txt"
    notes.write_text("my notes\n")
    document = json.loads((out / MANIFEST_NAME).read_text())
    document["version"] = version
    document["files"]["notes.txt"] = {"kind": "pack", "sha256": file_sha256(notes)}
    (out / MANIFEST_NAME).write_text(json.dumps(document))
    with pytest.raises(OutputFolderError, match=r"did not write .*\(notes.txt\)"):
        claim(out, kind="pack", force=force).replace({"expression_01.obj": "new\n"})
    assert notes.read_text() == "my notes\n"


def test_a_manifest_nested_too_deeply_is_no_manifest_and_nothing_is_removed(tmp_path) -> None:
    out = tmp_path / "out"
    claim(out, kind="pack", force=False).replace({"expression_01.obj": "ours\n"})
    (out / MANIFEST_NAME).write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(OutputFolderError, match=r"is not a harness manifest \(nested too deeply\)"):
        claim(out, kind="pack", force=True)
    assert (out / "expression_01.obj").read_text() == "ours\n"


def test_a_copied_output_is_not_the_commands_and_is_never_replaced(tmp_path) -> None:
    import shutil

    out = tmp_path / "out"
    claim(out, kind="pack", force=False).replace({"expression_01.obj": "ours\n"})
    copy = Path(shutil.copytree(out, tmp_path / "backup"))
    with pytest.raises(OutputFolderError, match=r"did not write .*\(expression_01.obj\)"):
        claim(copy, kind="pack", force=True)
    assert (copy / "expression_01.obj").read_text() == "ours\n"
    claim(out, kind="pack", force=True).replace({"expression_01.obj": "new\n"})  # (the original is ours)
    assert (out / "expression_01.obj").read_text() == "new\n"


def test_a_file_written_one_by_one_is_listed_with_its_inode_before_it_is_in_place(tmp_path) -> None:
    out = tmp_path / "out"
    folder = claim(out, kind="run", force=False)
    seen = []
    original = outdir.OutputFolder.save

    def save(self):
        seen.append((dict(self.files.get("run.json", {})), (out / "run.json").exists()))
        return original(self)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(outdir.OutputFolder, "save", save)
        path = folder.write("run.json", b"{}\n")
    assert seen == [({"kind": "run", "sha256": file_sha256(path), "inode": path.stat().st_ino}, False)]
    assert outdir.written_by(_listed(out)["run.json"], path)
    assert claim(out, kind="run", force=True).clear() == [path]


def test_a_linked_subfolder_is_refused_and_what_it_leads_to_kept(tmp_path) -> None:
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    out = tmp_path / "out"
    claim(out, kind="run", force=False).replace({"records/part.parquet": b"ours"})
    (outside / "part.parquet").write_bytes(b"ours")  # same content as the listed file
    (out / "records" / "part.parquet").unlink()
    (out / "records").rmdir()
    (out / "records").symlink_to(outside)
    with pytest.raises(OutputFolderError, match=r"did not write or that changed since \(records\)"):
        claim(out, kind="run", force=True)
    assert sorted(path.name for path in outside.iterdir()) == ["part.parquet"]
    assert (outside / "part.parquet").read_bytes() == b"ours"


def test_a_failed_write_keeps_the_old_content_and_leaves_nothing_behind(tmp_path, monkeypatch) -> None:
    out = tmp_path / "out"
    claim(out, kind="pack", force=False).replace({"expressions.json": "old\n"})
    folder = claim(out, kind="pack", force=True)

    def disk_full(descriptor: int) -> None:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "fsync", disk_full)
    with pytest.raises(
        OutputFolderError, match="expressions.json: cannot write .No space left on device"
    ) as error:
        folder.replace({"expressions.json": "new\n"})
    assert "\n" not in str(error.value)
    assert (out / "expressions.json").read_text() == "old\n"
    assert sorted(path.name for path in out.iterdir()) == [MANIFEST_NAME, "expressions.json"]
    assert _siblings(out) == []


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
    written = claim(tmp_path / "out", kind="pack", force=False).replace({"sub/b.txt": "x"})[0]
    assert written.stat().st_mode == reference.stat().st_mode
    folder_mode = (tmp_path / "out").stat().st_mode
    (tmp_path / "plain").mkdir()
    assert folder_mode == (tmp_path / "plain").stat().st_mode


@pytest.mark.parametrize("name", ["../x", "/abs", "a/../b", "", MANIFEST_NAME, "a//b", "a\\b"])
def test_names_outside_the_folder_are_refused(tmp_path, name: str) -> None:
    folder = claim(tmp_path / "out", kind="pack", force=False)
    with pytest.raises(OutputFolderError, match="is not a file name inside the output folder"):
        folder.replace({name: "x"})
    assert list((tmp_path / "out").iterdir()) == [] and _siblings(tmp_path / "out") == []


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
        ours = []
        if not user:
            ours = first
            claim(out, kind="pack", force=True).replace({name: f"first {name}".encode() for name in first})
        else:
            with pytest.raises(OutputFolderError):
                claim(out, kind="pack", force=True)
        edits = {name: b"edited " + name.encode() for name in edited if name in ours}
        for name, data in edits.items():
            (out / name).write_bytes(data)
        try:
            claim(out, kind="pack", force=True).replace({name: f"second {name}".encode() for name in second})
            replaced = True
        except OutputFolderError:
            replaced = False
        assert replaced == (not user and not edits)
        for name, data in {**user, **edits}.items():
            assert (out / name).read_bytes() == data
        if replaced:
            assert set(_listed(out)) == set(second)
            files = {path.relative_to(out).as_posix() for path in out.rglob("*") if path.is_file()}
            assert files == {*second, MANIFEST_NAME}
            for name in second:
                assert (out / name).read_bytes() == f"second {name}".encode()
        assert _siblings(out) == []


NAMED = ("b.obj", "sub/c.obj", "a.obj")


def test_a_whole_output_is_written_beside_the_folder_with_its_manifest_and_renamed_in_at_once(
    tmp_path, monkeypatch
) -> None:
    out = tmp_path / "out"
    claim(out, kind="pack", force=False).replace({"old.obj": "old\n"})
    folder = claim(out, kind="pack", force=True)
    swapped: list[Path] = []
    original_swap = outdir.swap_folder

    def swap(new: Path, target: Path) -> Path | None:
        assert target == out and new.parent == out.parent and new.name.startswith(".out.")
        assert sorted(path.name for path in out.iterdir()) == [MANIFEST_NAME, "old.obj"]  # as it was
        assert set(_listed(new)) == set(NAMED)  # the manifest lists every file before the rename
        assert all((new / name).is_file() for name in NAMED)
        swapped.append(new)
        return original_swap(new, target)

    monkeypatch.setattr(outdir, "swap_folder", swap)
    paths = folder.replace(dict(zip(NAMED, ("b\n", b"c\n", "a\n"), strict=True)))
    assert paths == [out / "b.obj", out / "sub" / "c.obj", out / "a.obj"] and len(swapped) == 1
    assert _listed(out) == folder.files and set(folder.files) == set(NAMED)
    assert not (out / "old.obj").exists() and _siblings(out) == []


def test_when_one_file_cannot_be_written_none_is_and_the_folder_is_as_it_was(tmp_path, monkeypatch) -> None:
    out = tmp_path / "out"
    claim(out, kind="pack", force=False).replace({"first.obj": "old first\n", "second.obj": "old second\n"})
    folder = claim(out, kind="pack", force=True)
    listed = _listed(out)
    original_write = outdir.atomic_write

    def fail_on_the_second_file(path: Path, payload: bytes, **options: bool) -> Path:
        if path.name in ("second.obj", "fourth.obj"):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return original_write(path, payload, **options)

    monkeypatch.setattr(outdir, "atomic_write", fail_on_the_second_file)
    new = {"first.obj": "new first\n", "second.obj": "new second\n", "third.obj": "3\n", "fourth.obj": "4\n"}
    with pytest.raises(OutputFolderError, match="second.obj: cannot write"):  # (the first failure in order)
        folder.replace(new)
    kept = [(out / name).read_text() for name in ("first.obj", "second.obj")]
    assert kept == ["old first\n", "old second\n"]
    assert folder.files == listed and _listed(out) == listed
    assert sorted(path.name for path in out.iterdir()) == [MANIFEST_NAME, "first.obj", "second.obj"]
    assert _siblings(out) == []


def test_contents_that_fail_while_being_made_leave_nothing_behind(tmp_path) -> None:
    out = tmp_path / "out"
    folder = claim(out, kind="pack", force=False)

    def contents():
        yield "a.obj", "a\n"
        yield "sub/b.obj", "b\n"
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        folder.replace(contents())
    assert folder.files == {} and list(out.iterdir()) == [] and _siblings(out) == []
    with pytest.raises(OutputFolderError, match="given twice"):
        folder.replace([("a.obj", "a\n"), ("a.obj", "again\n")])
    assert list(out.iterdir()) == [] and _siblings(out) == []


def test_a_whole_output_syncs_each_of_its_folders_once_then_the_parent(tmp_path, monkeypatch) -> None:
    folder = claim(tmp_path / "out", kind="pack", force=False)
    synced: list[Path] = []
    monkeypatch.setattr(atomic, "_sync_folder", synced.append)
    folder.replace({"a.obj": "a\n", "b.obj": "b\n", "sub/c.obj": "c\n", "sub/d.obj": "d\n"})
    staging = synced[0]
    assert staging.parent == tmp_path and staging.name.startswith(".out.")
    assert synced == [staging, staging / "sub", tmp_path]


def test_contents_that_come_one_by_one_are_written_as_they_come(tmp_path, monkeypatch) -> None:
    folder = claim(tmp_path / "out", kind="pack", force=False)
    written: list[str] = []
    original_write = outdir.atomic_write

    def recording(path: Path, payload: bytes, **options: bool) -> Path:
        written.append(path.name)
        return original_write(path, payload, **options)

    def contents():
        for index in range(20):
            assert written == [f"{number}.obj" for number in range(index)]  # (only one content is held)
            yield f"{index}.obj", f"{index}\n"

    monkeypatch.setattr(outdir, "atomic_write", recording)
    paths = folder.replace(contents())
    assert [path.name for path in paths] == [f"{index}.obj" for index in range(20)]
    assert all((tmp_path / "out" / f"{index}.obj").read_text() == f"{index}\n" for index in range(20))


@pytest.mark.parametrize("point", ["aside", "into place"])
def test_an_interrupted_swap_leaves_the_folder_as_it_was(tmp_path, monkeypatch, point) -> None:
    out = tmp_path / "out"
    claim(out, kind="pack", force=False).replace({"a.obj": "old a\n", "b.obj": "old b\n"})
    folder = claim(out, kind="pack", force=True)
    calls: list[str] = []
    original_rename = os.rename

    def rename(source, target) -> None:
        calls.append(str(target))
        if (point == "aside" and len(calls) == 2) or (point == "into place" and len(calls) == 3):
            raise KeyboardInterrupt  # (a stop signal is deferred past the swap; this is a failure in it)
        original_rename(source, target)

    monkeypatch.setattr(os, "rename", rename)
    with pytest.raises(KeyboardInterrupt):
        folder.replace({"a.obj": "new a\n", "sub/c.obj": "c\n"})
    monkeypatch.undo()
    assert {path.name: path.read_text() for path in out.iterdir() if path.name != MANIFEST_NAME} == {
        "a.obj": "old a\n",
        "b.obj": "old b\n",
    }
    again = claim(out, kind="pack", force=True)  # (what the manifest claims is on disk; leftovers go)
    assert _siblings(out) == []
    again.replace({"a.obj": "x\n", "b.obj": "y\n", "sub/c.obj": "z\n"})  # (a --force rerun works)


def test_a_file_made_in_the_folder_while_the_contents_are_made_stops_the_replacement(tmp_path) -> None:
    out = tmp_path / "out"
    folder = claim(out, kind="pack", force=False)

    def contents():
        yield "mine.obj", "harness\n"
        (out / "mine.obj").write_text("the user's file\n")
        yield "other.obj", "harness\n"

    with pytest.raises(OutputFolderError, match=r"holds no harness output \(mine.obj\)"):
        folder.replace(contents())
    assert (out / "mine.obj").read_text() == "the user's file\n"
    assert sorted(path.name for path in out.iterdir()) == ["mine.obj"] and folder.files == {}
    assert _siblings(out) == []


def test_a_failed_file_stops_the_contents_and_nothing_is_left(tmp_path, monkeypatch) -> None:
    out = tmp_path / "out"
    folder = claim(out, kind="pack", force=False)
    made: list[int] = []

    def full_disk(path: Path, payload: bytes, **options: bool) -> Path:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    def contents():
        for index in range(30):
            made.append(index)
            yield f"deep/er/{index}.obj", f"{index}\n"

    monkeypatch.setattr(outdir, "atomic_write", full_disk)
    with pytest.raises(OutputFolderError, match=r"deep/er/0\.obj: cannot write .No space left on device"):
        folder.replace(contents())
    assert made == [0]  # (not every content was made)
    assert list(out.iterdir()) == [] and folder.files == {} and _siblings(out) == []


def test_a_name_cannot_be_both_a_file_and_a_folder_in_one_write(tmp_path) -> None:
    folder = claim(tmp_path / "out", kind="pack", force=False)
    for names in (["d/e.obj", "d"], ["d", "d/e.obj"]):
        with pytest.raises(OutputFolderError, match="both a file and a folder"):
            folder.replace([(name, "x\n") for name in names])
        assert list((tmp_path / "out").iterdir()) == [] and _siblings(tmp_path / "out") == []


def test_an_output_folder_that_is_a_symbolic_link_is_named_as_one(tmp_path):
    (tmp_path / "real").mkdir()
    (tmp_path / "link").symlink_to(tmp_path / "real")
    with pytest.raises(OutputFolderError, match=r"link: is a symbolic link; give the folder it points to"):
        claim(tmp_path / "link", kind="pack", force=False)
    assert not any((tmp_path / "real").iterdir())
