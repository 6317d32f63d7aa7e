"""Worker processes: functions run in a persistent child interpreter that may crash, hang or be killed.

One layer serves every caller that must not share a process with what it runs (docs/architecture.md,
"Solver libraries that do not share a process"): python-mip's CBC fails to load beside OR-Tools in one
process, so that backend solves in a worker of its own (`worker`, behind the same ``Solver.solve``); the
harness runs every grid cell in one, so that a solver that segfaults, hangs past ``--timeout`` or is
killed loses that cell and not the run.

A `Worker` starts ``python -m solvers._worker_child`` (a fresh interpreter, never a fork: solver libraries
keep threads and global state) on first use, talks to it over a socket pair (`multiprocessing.connection`
framing, `pickle` payloads) and restarts it on the call after it died or was stopped. Functions are named
``"module:function"`` and run in order; interpreter and library start-up are paid once per process, never
inside a call. A worker ignores Ctrl-C and runs in a session of its own: its parent stops it (a blocking
`Worker.call` interrupted by Ctrl-C does), and it ends with its parent even when that is killed with
``kill -9`` (`solvers._worker_child.exit_with_parent`). Every reply carries the CPU seconds its call took in
the worker, summed per calling process in `worker_cpu_seconds`, so that a solve timed by its CPU counts
the work its backend did in a worker too (`solvers.cpu_seconds`).
"""

from __future__ import annotations

import atexit
import contextlib
import multiprocessing.connection
import os
import pickle
import signal
import subprocess
import sys
import tempfile
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import IO

from solvers import _strays as strays

_cpu_lock = threading.Lock()
_cpu_total = [0.0]


def worker_cpu_seconds() -> float:
    """CPU seconds the calls of this process's workers took in them, so far (replies received)."""
    with _cpu_lock:
        return _cpu_total[0]


#: Seconds a worker may take to exit once its connection is closed, before it is killed.
STOP_GRACE = 5.0
#: Characters of a worker's log quoted in an error message.
LOG_TAIL = 2000


class WorkerError(RuntimeError):
    """A call to a worker failed: its function raised, or no reply came within the call's timeout."""


class WorkerDied(WorkerError):
    """The worker process ended before it replied (it crashed or was killed).

    Attributes
    ----------
    pid : int
        The process id it had.
    returncode : int
        Its exit status; minus the signal number when a signal ended it.
    """

    def __init__(self, message: str, pid: int, returncode: int) -> None:
        super().__init__(message)
        self.pid = pid
        self.returncode = returncode

    @property
    def exit(self) -> str:
        """How the process ended: ``killed by SIGKILL`` or ``exit code 1``."""
        return describe_exit(self.returncode)


def describe_exit(returncode: int) -> str:
    """A process's exit status in words: ``killed by SIGSEGV``, ``exit code 3``."""
    if returncode < 0:
        try:
            return f"killed by {signal.Signals(-returncode).name}"
        except ValueError:
            return f"killed by signal {-returncode}"
    return f"exit code {returncode}"


class Worker:
    """One persistent child process that runs functions named ``"module:function"``.

    `call` runs one function and waits for its result. An owner that waits on several workers at once
    starts calls with `send`, waits with `wait_for_workers` and collects the replies with `receive`, in
    the order the calls were sent.

    Parameters
    ----------
    label : str
        Name used in error messages (a solver plugin's name).
    log : bool
        True: the worker's standard output and error go to a private log whose tail error messages quote
        (library output never reaches the caller's terminal). False: its output is discarded and its
        error stream is the caller's.
    """

    def __init__(self, label: str, *, log: bool = True) -> None:
        self.label = label
        self.log = log
        self._process: subprocess.Popen[bytes] | None = None
        self._connection: multiprocessing.connection.Connection | None = None
        self._log: IO[bytes] | None = None
        self._pending = 0
        self._lock = threading.Lock()

    @property
    def pid(self) -> int | None:
        """The worker's process id, or None when it is not running."""
        return None if self._process is None else self._process.pid

    @property
    def pending(self) -> int:
        """Calls sent whose replies have not been received."""
        return self._pending

    def fileno(self) -> int:
        """The descriptor that turns readable when a reply comes or the process ends (`wait_for_workers`)."""
        if self._connection is None:
            raise ValueError(f"{self.label} worker is not running")
        return self._connection.fileno()

    def ready(self) -> bool:
        """True when `receive` would not wait: a reply came, or the process ended."""
        return self._connection is not None and self._connection.poll()

    def send(self, function: str, *args: object) -> None:
        """Start ``function(*args)`` in the worker, starting the process first if it is not running.

        Raises
        ------
        WorkerDied
            The process ended before it took the call (it is then stopped; the next call restarts it).
        """
        self._send(function, args)

    def receive(self) -> object:
        """The result of the oldest call sent, waiting for it if need be.

        Raises
        ------
        WorkerError
            With the worker's traceback when the function raised (the worker goes on).
        WorkerDied
            When the process ended first (it is then stopped; the next call restarts it).
        """
        if self._connection is None or not self._pending:
            raise WorkerError(f"{self.label} worker: no call is waiting for a reply")
        try:
            succeeded, value, cpu = pickle.loads(self._connection.recv_bytes())
        except (EOFError, OSError):
            raise self._died() from None
        self._pending -= 1
        with _cpu_lock:
            _cpu_total[0] += float(cpu)
        if not succeeded:
            raise WorkerError(f"{self.label} worker: {value}")
        return value

    def call(self, function: str, *args: object, timeout: float | None = None) -> object:
        """Run ``function(*args)`` in the worker and return its result.

        Parameters
        ----------
        function : str
            ``"module:function"``, importable in the worker.
        *args
            Its arguments (pickled).
        timeout : float, optional
            Seconds to wait for the reply; the worker is stopped when none comes.

        Raises
        ------
        WorkerError
            The function raised, or no reply came within ``timeout``.
        WorkerDied
            The process ended first (a crash, a kill).

        Notes
        -----
        Calls from several threads take turns. A dead, timed-out or interrupted worker is stopped and the
        next call starts a fresh one.
        """
        with self._lock:
            connection = self._send(function, args)
            try:
                if not connection.poll(timeout):
                    detail = self._log_tail()
                    self.stop()
                    message = f"{self.label} worker process gave no reply within {timeout:.0f} s. {detail}"
                    raise WorkerError(message.strip())
                return self.receive()
            except WorkerError:
                raise
            except BaseException:  # Ctrl-C: the late reply would answer the next call
                self.stop()
                raise

    def stop(self) -> None:
        """End the process: at once when a call is in flight, else by closing its connection.

        Replies not received are lost. The next `send` or `call` starts a fresh process.
        """
        process, connection = self._process, self._connection
        self._process, self._connection = None, None
        if process is not None:
            if self._pending:
                process.kill()
            if connection is not None:
                connection.close()
            try:
                process.wait(timeout=STOP_GRACE)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(process.pid, signal.SIGKILL)  # (what it started and left: its session's group)
            strays.note_helper(process.pid, running=False)
        self._pending = 0
        if self._log is not None:
            self._log.close()
            self._log = None

    def _send(self, function: str, args: tuple[object, ...]) -> multiprocessing.connection.Connection:
        """Send one call (see `send`); the connection it went over."""
        connection = self._started()
        payload = pickle.dumps((function, args), protocol=pickle.HIGHEST_PROTOCOL)
        try:
            connection.send_bytes(payload)
        except OSError:
            raise self._died() from None
        self._pending += 1
        return connection

    def _started(self) -> multiprocessing.connection.Connection:
        """The connection to a running process (started, or restarted after it ended)."""
        if self._process is not None and self._connection is not None and self._process.poll() is None:
            return self._connection
        self.stop()
        output: IO[bytes] | int = subprocess.DEVNULL
        if self.log:
            output = self._log = tempfile.TemporaryFile(prefix=f"worker-{self.label}-")
        mine, theirs = multiprocessing.connection.Pipe()  # a socket pair on POSIX
        with theirs:
            self._process = subprocess.Popen(
                [sys.executable, "-m", "solvers._worker_child", str(theirs.fileno()), str(os.getpid())],
                pass_fds=[theirs.fileno()],
                env={**os.environ, "PYTHONPATH": _import_path()},
                stdin=subprocess.DEVNULL,
                stdout=output,
                stderr=output if self.log else None,
                start_new_session=True,  # Ctrl-C reaches the caller only; the caller stops its workers
            )
        strays.note_helper(self._process.pid, running=True)
        self._connection = mine
        return mine

    def _died(self) -> WorkerDied:
        """The error for a process that ended before it replied; the worker is stopped."""
        assert self._process is not None
        process, detail = self._process, self._log_tail()
        self._pending = 0  # its end of the connection closed: it is exiting, let it finish
        self.stop()
        message = f"{self.label} worker process {process.pid} died ({describe_exit(process.returncode)})."
        return WorkerDied(f"{message} {detail}".strip(), process.pid, process.returncode)

    def _log_tail(self) -> str:
        if self._log is None:
            return ""
        self._log.seek(0)
        text = self._log.read().decode(errors="replace").strip()
        return f"Worker log: {text[-LOG_TAIL:]}" if text else ""


def wait_for_workers(workers: Sequence[Worker], timeout: float | None = None) -> None:
    """Wait until one of ``workers`` has a reply to receive or its process ended, or ``timeout`` seconds.

    The caller then asks each worker whether it is `Worker.ready`.
    """
    multiprocessing.connection.wait(workers, timeout=timeout)  # type: ignore[arg-type]


def _import_path() -> str:
    """``PYTHONPATH`` for a worker: this project's root, then the caller's ``sys.path`` (plugin folders
    added at run time included), so that a function resolves in the worker as it does in the caller."""
    root = str(Path(__file__).resolve().parent.parent)
    return os.pathsep.join(dict.fromkeys(path for path in (root, *sys.path) if path))


_WORKERS: dict[str, Worker] = {}
_WORKERS_LOCK = threading.Lock()


def worker(label: str) -> Worker:
    """The shared persistent worker of one backend (created on first use, stopped at interpreter exit)."""
    with _WORKERS_LOCK:
        if label not in _WORKERS:
            _WORKERS[label] = Worker(label)
        return _WORKERS[label]


@atexit.register
def _stop_all() -> None:
    for running in list(_WORKERS.values()):
        running.stop()
