"""`harness._journal`: a cell's finished expression rows, read back after its process was killed."""

from __future__ import annotations

import tempfile

from harness._journal import append_row, new_journal, read_journal, remove_journal


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
