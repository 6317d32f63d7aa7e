"""Processes a plugin leaves behind in a worker process (`solvers.Worker`): a solver may fork, and a forked
copy of the worker that returns from ``solve`` would answer the call a second time, while one that lingers
keeps the worker's output streams open (a ``harness run | tee`` then never ends).

A worker process marks itself (`mark_worker`) and becomes its descendants' *subreaper* (Linux): an orphan
of a process it started is re-parented to it, so `children` sees every process the plugin started,
double-forked ones too (but the `solvers.Worker` processes it starts itself, `note_helper`).
`solvers.LoadedSolver` compares the worker's children before and after each solve,
ends the new ones (`stop`) and answers the solve as failed; outside a worker nothing is looked at (the
harness's own process shares its process group with the user's pipeline).
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import sys
from pathlib import Path

#: ``prctl`` option making this process the reaper of its orphaned descendants (``<linux/prctl.h>``).
_PR_SET_CHILD_SUBREAPER = 36

_worker = False
#: Processes of `solvers.Worker`s this process started (a backend's persistent worker): no strays.
_helpers: set[int] = set()


def note_helper(pid: int, running: bool) -> None:
    """Note that this process started (``running``) or stopped the `solvers.Worker` process ``pid``."""
    if running:
        _helpers.add(pid)
    else:
        _helpers.discard(pid)


def mark_worker() -> None:
    """Mark this process as a worker: `children` looks at its children from now on (Linux)."""
    global _worker
    _worker = True
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):
            ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0)


def children() -> set[int]:
    """The process ids of this worker's children, running or ended but not waited for, but the
    `solvers.Worker` processes it started (`note_helper`); empty outside a worker or where ``/proc`` does
    not list children."""
    if not _worker:
        return set()
    found: set[int] = set()
    for task in Path("/proc/self/task").glob("*/children"):
        with contextlib.suppress(OSError):
            found.update(int(pid) for pid in task.read_text().split())
    return found - _helpers


def stop(pids: set[int]) -> None:
    """End the processes ``pids`` (children of this process) and wait for them."""
    for pid in pids:
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.kill(pid, signal.SIGKILL)
    for pid in pids:
        with contextlib.suppress(ChildProcessError):
            os.waitpid(pid, 0)
