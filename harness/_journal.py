"""A cell's journal: the ``expression`` rows it finished, written as it goes and read back when it is stopped.

A cell stopped by ``--timeout`` is killed with its worker process, so it cannot return the expressions it
had solved. `harness._executors.LocalExecutor` gives each cell a journal file of its own (`new_journal`, in
the machine's temporary directory: never in a run folder, so never taken for a part file or for a temporary
file of one, and local to the machine even when a Dask worker runs the cell), `harness._cell.run_cell`
appends each finished expression's row to it as one JSON line (`append_row`), then a `SEQUENCE_END` line
once the sequence is whole, and on a timeout the executor reads the rows back (`read_journal`) to record
them beside the ``timeout`` cell row, saying whether the sequence was cut or the time ran out after it.
The executor removes the journal once the cell's outcome is known, however the cell ended
(`remove_journal`). A harness process killed outright (``kill -9``, a lost machine) cannot: its journals are
named after its host, process id namespace and process id, and the next executor started there removes
those of processes that no longer exist (`remove_orphaned_journals`).
"""

from __future__ import annotations

import json
import os
import re
import socket
import stat
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from registry import append_text

if TYPE_CHECKING:
    from harness._rows import RecordValue, Row

#: ``kind`` of the line a cell appends once its whole sequence is solved (checks and transfers follow).
SEQUENCE_END = "sequence_end"

#: Prefix and suffix of journal file names: ``harness-cell-<origin>.<pid>.<random>.journal``.
_PREFIX, _SUFFIX = "harness-cell-", ".journal"
#: A journal's name, read back: where and by which process it was made.
_NAME = re.compile(re.escape(_PREFIX) + r"(?P<origin>.+)\.(?P<pid>\d+)\.[^.]+" + re.escape(_SUFFIX))


def new_journal() -> Path:
    """An empty journal file of its own, in the temporary directory, named after where this process runs
    (`_origin`) and its id."""
    descriptor, name = tempfile.mkstemp(prefix=f"{_PREFIX}{_origin()}.{os.getpid()}.", suffix=_SUFFIX)
    os.close(descriptor)
    return Path(name)


def remove_orphaned_journals() -> list[Path]:
    """Remove this user's journals whose process, on this host and in this process id namespace, no longer
    exists (a harness killed outright could not remove them).

    Returns
    -------
    list of Path
        The journals removed.

    Notes
    -----
    Only on POSIX systems, where a process's existence is asked with signal 0 (``os.kill(pid, 0)``, which on
    Windows would end the process). A journal made on another host or in another process id namespace (a
    container sharing this temporary directory) is never removed, nor is one whose process id a live process
    holds again, nor any file that is not a regular file of this user's; a file that cannot be removed is
    left.
    """
    if os.name != "posix":
        return []
    origin, user, removed = _origin(), os.getuid(), []
    for path in Path(tempfile.gettempdir()).glob(f"{_PREFIX}*{_SUFFIX}"):
        named = _NAME.fullmatch(path.name)
        if named is None or named["origin"] != origin or _running(int(named["pid"])):
            continue
        try:
            status = path.lstat()
            if not stat.S_ISREG(status.st_mode) or status.st_uid != user:
                continue
            path.unlink()
        except OSError:  # (gone meanwhile, or not ours to remove)
            continue
        removed.append(path)
    return removed


def _origin() -> str:
    """This host's name and, where the system has them, the inode of this process's id namespace: a
    process id means one process only within both."""
    try:
        namespace = os.stat("/proc/self/ns/pid").st_ino
    except OSError:
        namespace = 0
    return f"{socket.gethostname()}.{namespace}"


def _running(pid: int) -> bool:
    """Whether a process ``pid`` exists (one of another user's counts)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True
    return True


def append_row(journal: str | os.PathLike, row: Mapping[str, RecordValue]) -> None:
    """Append one row as a JSON line, flushed before this returns (the process may be killed next)."""
    append_text(journal, json.dumps(dict(row)) + "\n")


def read_journal(journal: str | os.PathLike) -> list[Row]:
    """The rows of a journal, in the order written; none when it is missing.

    A process killed while appending may leave a last line cut short: reading stops at the first line
    that is not one whole JSON row.
    """
    try:
        text = Path(journal).read_text(encoding="utf-8")
    except FileNotFoundError:
        return []
    rows: list[Row] = []
    for line in text.splitlines(keepends=True):
        try:
            row = json.loads(line)
        except json.JSONDecodeError:
            break
        if not line.endswith("\n") or not isinstance(row, dict):
            break
        rows.append(row)
    return rows


def remove_journal(journal: str | os.PathLike) -> None:
    """Delete a journal (nothing when it is already gone)."""
    Path(journal).unlink(missing_ok=True)
