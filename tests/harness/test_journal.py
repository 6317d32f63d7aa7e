"""`harness._journal`: a cell's finished expression rows, read back after its process was killed."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import tempfile

from harness._executors import LocalExecutor
from harness._journal import append_row, new_journal, read_journal, remove_journal, remove_orphaned_journals


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


def test_journals_of_processes_gone_are_removed_and_no_other_file(tmp_path, monkeypatch) -> None:
    """A harness killed outright leaves its journals: the next one on the host removes those of processes
    that no longer exist, never a live process's, another host's or a file it did not name."""
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    mine = new_journal()
    host = socket.gethostname()
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()
    orphan = tmp_path / f"harness-cell-{host}.{gone.pid}.abc123_x.journal"
    elsewhere = tmp_path / f"harness-cell-other-{host}.{gone.pid}.abc123_x.journal"
    foreign = tmp_path / f"harness-cell-{host}.{gone.pid}.notes.txt"
    for path in (orphan, elsewhere, foreign):
        path.write_text("{}\n", encoding="utf-8")
    if os.name != "posix":
        assert remove_orphaned_journals() == []
        return
    assert remove_orphaned_journals() == [orphan]
    assert sorted(tmp_path.iterdir()) == sorted([mine, elsewhere, foreign])
    assert mine.name.startswith(f"harness-cell-{host}.{os.getpid()}.")


def test_an_executor_removes_orphaned_journals(tmp_path, monkeypatch) -> None:
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()
    orphan = tmp_path / f"harness-cell-{socket.gethostname()}.{gone.pid}.zz9_q.journal"
    orphan.write_text("", encoding="utf-8")
    executor = LocalExecutor(jobs=1)
    try:
        assert orphan.exists() is (os.name != "posix")
    finally:
        executor.close()
