"""Persistent worker processes for backends that cannot share a process with the others.

DESIGN.md, "Pitfalls": python-mip's CBC fails to load beside OR-Tools in one process. Such a backend runs
its ``module:function`` in a long-lived ``python -m solvers._worker`` child: requests and replies are
pickled over the child's stdin and a private copy of its stdout (library output on fd 1 goes to a log
file instead), so the caller's ``Solver.solve`` looks the same as for an in-process backend. The first
call starts the worker (interpreter and library start-up are paid once and never counted as solve time).
The worker ends with its parent, even when the parent is killed with ``kill -9`` (`exit_with_parent`).
"""

from __future__ import annotations

import atexit
import ctypes
import importlib
import os
import pickle
import select
import signal
import subprocess
import sys
import tempfile
import threading
import time
import traceback
from pathlib import Path
from typing import Any


class WorkerError(RuntimeError):
    """The worker process failed: it crashed, timed out, or its function raised."""


class Worker:
    """One persistent child process that runs functions by ``"module:function"`` name.

    Parameters
    ----------
    label : str
        Name used in error messages (the solver plugin's name).
    """

    def __init__(self, label: str) -> None:
        self.label = label
        self._process: subprocess.Popen | None = None
        self._log = None
        self._lock = threading.Lock()

    def call(self, function: str, *args: Any, timeout: float | None = None) -> Any:
        """Run ``function(*args)`` in the worker and return its result.

        Raises
        ------
        WorkerError
            With the worker's traceback or the tail of its log when it died; a dead or timed-out
            worker is discarded and the next call starts a fresh one.
        """
        with self._lock:
            process = self._ensure_started()
            try:
                pickle.dump((function, args), process.stdin, protocol=pickle.HIGHEST_PROTOCOL)
                process.stdin.flush()
                if timeout is not None and os.name == "posix":
                    ready, _, _ = select.select([process.stdout], [], [], timeout)
                    if not ready:
                        raise TimeoutError(f"no reply within {timeout:.0f} s")
                status, value = pickle.load(process.stdout)
            except (OSError, EOFError, pickle.UnpicklingError, TimeoutError) as error:
                detail = self._log_tail()
                self._stop(kill=True)
                raise WorkerError(f"{self.label} worker process failed ({error}). {detail}".strip()) from None
        if status == "error":
            raise WorkerError(f"{self.label} worker: {value}")
        return value

    def close(self) -> None:
        """Stop the worker process (it is restarted by the next call)."""
        with self._lock:
            self._stop()

    def _ensure_started(self) -> subprocess.Popen:
        if self._process is not None and self._process.poll() is None:
            return self._process
        self._stop()
        self._log = tempfile.TemporaryFile(prefix=f"harness-{self.label}-")
        env = dict(os.environ)
        package_root = str(Path(__file__).resolve().parent.parent)
        env["PYTHONPATH"] = os.pathsep.join(p for p in (package_root, env.get("PYTHONPATH", "")) if p)
        self._process = subprocess.Popen(
            [sys.executable, "-m", "solvers._worker", str(os.getpid())],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self._log,
            env=env,
        )
        return self._process

    def _log_tail(self, limit: int = 2000) -> str:
        if self._log is None:
            return ""
        self._log.seek(0)
        text = self._log.read().decode(errors="replace").strip()
        return f"Worker log: {text[-limit:]}" if text else ""

    def _stop(self, kill: bool = False) -> None:
        process, self._process = self._process, None
        if process is not None:
            if kill:
                process.kill()
            for stream in (process.stdin, process.stdout):
                try:
                    stream.close()
                except OSError:
                    pass
            try:
                process.wait(timeout=5)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
        if self._log is not None:
            self._log.close()
            self._log = None


_WORKERS: dict[str, Worker] = {}
_WORKERS_LOCK = threading.Lock()


def worker(label: str) -> Worker:
    """The persistent worker of one backend (created on first use, stopped at interpreter exit)."""
    with _WORKERS_LOCK:
        if label not in _WORKERS:
            _WORKERS[label] = Worker(label)
        return _WORKERS[label]


@atexit.register
def _close_all() -> None:
    for running in list(_WORKERS.values()):
        running.close()


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


def _resolve(function: str):
    module, _, name = function.partition(":")
    return getattr(importlib.import_module(module), name)


def main() -> None:
    """Worker loop: read ``(function, args)`` pickles from stdin, write ``(status, value)`` replies.

    ``sys.argv[1]`` is the parent's process id: the worker ends with it (`exit_with_parent`).
    """
    exit_with_parent(int(sys.argv[1]))
    requests = sys.stdin.buffer
    replies = os.fdopen(os.dup(sys.stdout.fileno()), "wb")
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())  # C libraries printing to fd 1 must not corrupt replies
    sys.stdout = sys.stderr
    while True:
        try:
            function, args = pickle.load(requests)
        except EOFError:
            return
        try:
            reply = ("ok", _resolve(function)(*args))
        except BaseException:  # report everything; the parent decides
            reply = ("error", traceback.format_exc())
        pickle.dump(reply, replies, protocol=pickle.HIGHEST_PROTOCOL)
        replies.flush()


if __name__ == "__main__":
    main()
