"""The worker process's side of `solvers._worker`: ``python -m solvers._worker_child FD PARENT``.

It reads pickled ``(function, args)`` calls from the connected socket FD, runs ``function(*args)``
(named ``"module:function"``) and answers each with ``(True, result, cpu)``, or ``(False, traceback, cpu)``
when the call cannot be read, the function raised, or its result cannot be pickled; ``cpu`` is the CPU
seconds the call took in this process (every thread) and in the child processes it waited for. A closed
connection ends it, and so does the end of the process PARENT, however that ends (`exit_with_parent`).
Ctrl-C is ignored: the parent stops its workers itself. A copy of the process a call forked never answers,
and the processes a solver leaves behind are ended (`solvers._strays`).
"""

from __future__ import annotations

import ctypes
import importlib
import multiprocessing.connection
import os
import pickle
import resource
import signal
import sys
import threading
import time
import traceback
from collections.abc import Callable

from solvers._strays import mark_worker

#: ``prctl`` option asking the kernel for a signal when the parent exits (``<linux/prctl.h>``).
_PR_SET_PDEATHSIG = 1
#: Seconds between two checks of the parent by the watchdog thread.
_WATCH_INTERVAL = 1.0


def exit_with_parent(parent: int) -> None:
    """End this process as soon as ``parent`` (the process that started it) ends, however it ends.

    On Linux the kernel sends SIGKILL when the parent exits (``prctl(PR_SET_PDEATHSIG)``, through
    `ctypes`); on every platform a daemon thread checks every `_WATCH_INTERVAL` seconds that the parent
    is still this process's parent (an orphan is re-parented) and exits otherwise. A parent already gone
    by the time this runs ends the process at once.
    """
    if sys.platform.startswith("linux"):
        try:
            ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
        except (OSError, AttributeError):
            pass  # no usable libc: the watchdog below still ends the process
    if os.getppid() != parent:
        os._exit(1)
    threading.Thread(target=_watch_parent, args=(parent,), name="parent-watchdog", daemon=True).start()


def _watch_parent(parent: int) -> None:
    while os.getppid() == parent:
        time.sleep(_WATCH_INTERVAL)
    os._exit(1)


def _resolve(function: str) -> Callable[..., object]:
    module, _, name = function.partition(":")
    return getattr(importlib.import_module(module), name)


def _cpu() -> float:
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime


def _answer(request: bytes) -> bytes:
    """The pickled reply to one pickled call (a copy of this process the call forked ends instead: only
    the worker itself answers)."""
    start, pid = _cpu(), os.getpid()
    try:
        function, args = pickle.loads(request)
        result = _resolve(function)(*args)
        reply = (True, result, _cpu() - start)
    except BaseException:  # report everything; the parent decides
        reply = (False, traceback.format_exc(), _cpu() - start)
    if os.getpid() != pid:
        os._exit(0)
    try:
        return pickle.dumps(reply, protocol=pickle.HIGHEST_PROTOCOL)
    except BaseException:  # a result that cannot be pickled
        return pickle.dumps((False, traceback.format_exc(), _cpu() - start))


def serve(connection: multiprocessing.connection.Connection) -> None:
    """Answer calls until the connection closes."""
    while True:
        try:
            connection.send_bytes(_answer(connection.recv_bytes()))
        except (EOFError, OSError):  # the parent closed the connection, or is gone
            return


def main() -> None:
    """Serve the connection ``sys.argv[1]`` for the process ``sys.argv[2]``."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    exit_with_parent(int(sys.argv[2]))
    mark_worker()
    serve(multiprocessing.connection.Connection(int(sys.argv[1])))


if __name__ == "__main__":
    main()
