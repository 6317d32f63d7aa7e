"""Cells whose work did not end: the crashes a run counts, and the cells ``--retry-failed`` runs again.

A worker process that dies or fails while warming up or running a cell (`harness._cell.Lost` with
``crash``) loses the cell the first time: it may have been the machine (a kill, the out-of-memory killer).
The `CRASH_LIMIT`-th crash of the same cell, in the session that runs it again, records it ``crashed`` with
how the process ended (``killed by SIGSEGV``), so that a solver that crashes on every input cannot keep a
run from completing. The counts live in ``run.json``'s ``crashes`` (`harness._run`) until the cell has a
part file.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from harness._cell import Lost, failure_rows
from harness._grid import CellSpec
from harness._records import read_records
from harness._rows import Row

#: Crashes of a cell's worker process after which the cell is recorded ``crashed`` instead of lost again.
CRASH_LIMIT = 2
#: Cell statuses ``--resume --retry-failed`` runs again: the cell's work did not end (stopped by
#: ``--timeout``, its worker crashed, or it raised).
RETRIED_STATUSES = ("timeout", "crashed", "error")


def count_crash(crashes: dict[str, dict[str, Any]], spec: CellSpec, lost: Lost) -> Lost | list[Row]:
    """Count a crash of a cell's worker process in ``crashes`` (cell id -> ``{"cell": label, "count": n,
    "exit": how}``): the cell is lost until its `CRASH_LIMIT`-th crash, whose rows record it ``crashed``,
    naming how the process ended."""
    entry = crashes.setdefault(spec.id, {"cell": spec.label(), "count": 0})
    entry["count"] += 1
    entry["exit"] = lost.crash
    if entry["count"] < CRASH_LIMIT:
        return Lost(f"{lost.reason} (crash {entry['count']} of {CRASH_LIMIT}; the last is recorded crashed)")
    message = f"its worker process crashed on it {entry['count']} times (last: {lost.crash})"
    return failure_rows(spec, "crashed", message)


def failed_cells(out: Path) -> set[str]:
    """The cells of the run in ``out`` recorded with one of `RETRIED_STATUSES`."""
    try:
        records = read_records(out)
    except FileNotFoundError:
        return set()
    cells = records[(records["kind"] == "cell") & records["status"].isin(RETRIED_STATUSES)]
    return set(cells["cell"])
