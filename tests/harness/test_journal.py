"""`harness._journal`: a cell's finished expression rows, read back after its process was killed."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import tempfile
from pathlib import Path

from harness._executors import LocalExecutor
from harness._journal import (
    _origin,
    append_row,
    new_journal,
    read_journal,
    remove_journal,
    remove_orphaned_journals,
)


def test_rows_read_back_in_order_and_a_line_cut_by_a_kill_is_dropped(tmp_path, monkeypatch) -> None:
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    journal = new_journal()
    assert journal.parent == tmp_path and read_journal(journal) == []
    append_row(journal, {"kind": "expression", "expression": 1, "shapes": ["a", "b"], "bound": None})
    append_row(journal, {"kind": "expression", "expression": 2, "objective": 0.5, "optimal": True})
    with open(journal, "a", encoding="utf-8") as stream:
        stream.write('{"kind": "expression", "expre')
    assert read_journal(journal) == [
        {"kind": "expression", "expression": 1, "shapes": ["a", "b"], "bound": None},
        {"kind": "expression", "expression": 2, "objective": 0.5, "optimal": True},
    ]
    remove_journal(journal)
    remove_journal(journal)
    assert read_journal(journal) == [] and list(tmp_path.iterdir()) == []


def _gone_pid() -> int:
    """The id of a process that has ended."""
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()
    return gone.pid


def test_journals_of_processes_gone_are_removed_and_no_other_file(tmp_path, monkeypatch) -> None:
    """A harness killed outright leaves its journals: the next one removes those of processes that no longer
    exist, never a live process's, another host's or namespace's, or a file it did not name."""
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    mine = new_journal()
    origin, pid = _origin(), _gone_pid()
    orphan = tmp_path / f"harness-cell-{origin}.{pid}.abc123_x.journal"
    elsewhere = tmp_path / f"harness-cell-other-{socket.gethostname()}.0.{pid}.abc123_x.journal"
    other_namespace = tmp_path / f"harness-cell-{socket.gethostname()}.1.{pid}.abc123_x.journal"
    unnamed = tmp_path / f"harness-cell-{origin}.{pid}.journal"
    foreign = tmp_path / f"harness-cell-{origin}.{pid}.notes.txt"
    folder = tmp_path / f"harness-cell-{origin}.{pid}.dir_x.journal"
    for path in (orphan, elsewhere, other_namespace, unnamed, foreign):
        path.write_text("{}\n", encoding="utf-8")
    folder.mkdir()
    if os.name != "posix":
        assert remove_orphaned_journals() == []
        return
    assert mine.name.startswith(f"harness-cell-{origin}.{os.getpid()}.")
    assert remove_orphaned_journals() == [orphan]
    assert sorted(tmp_path.iterdir()) == sorted([mine, elsewhere, other_namespace, unnamed, foreign, folder])


def test_a_journal_that_cannot_be_removed_is_left(tmp_path, monkeypatch) -> None:
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    orphan = tmp_path / f"harness-cell-{_origin()}.{_gone_pid()}.q1w2e3.journal"
    orphan.write_text("", encoding="utf-8")

    def refuse(self, missing_ok=False):
        raise PermissionError(13, "Permission denied", str(self))

    monkeypatch.setattr(Path, "unlink", refuse)
    assert remove_orphaned_journals() == []
    assert orphan.exists()


def test_an_executor_removes_orphaned_journals(tmp_path, monkeypatch) -> None:
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    orphan = tmp_path / f"harness-cell-{_origin()}.{_gone_pid()}.zz9_q.journal"
    orphan.write_text("", encoding="utf-8")
    executor = LocalExecutor(jobs=1)
    try:
        assert orphan.exists() is (os.name != "posix")
    finally:
        executor.close()
