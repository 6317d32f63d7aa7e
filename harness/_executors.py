"""Executors: where cells run. Local worker processes (the default) or a Dask distributed cluster.

Both hand every cell to `harness._cell.run_cell` in a process of their own and yield ``(spec, outcome)`` as
cells finish, in completion order; the caller writes the rows. A cell that exceeds ``timeout`` seconds is
stopped by killing its process and yields one ``timeout`` row: that is a result of the cell. What is no
result of the cell yields `harness._cell.Lost` with the reason, and ``--resume`` runs the cell again: a
worker process that dies (killed, out of memory), a worker whose start-up and warm-up exceed their
allowance, a Dask task that fails (scheduler or worker lost, the package missing on a worker).

Local workers are fresh interpreters (`harness._worker`, started with `subprocess`, never forked: solver
libraries keep threads and global state, and Dask's daemonic worker processes may not use
`multiprocessing` children) talking over a socket pair, reused from cell to cell. Each does one untimed
warm-up solve per solver before its first cell with that solver (see `harness._cell.warm_up`). Start-up and
warm-up may take ``timeout`` plus `STARTUP_ALLOWANCE` seconds; the cell then gets the full ``timeout``.
Workers end with the process that started them, even when it is killed with ``kill -9``.
"""

from __future__ import annotations

import logging
import multiprocessing.connection
import os
import signal
import socket
import subprocess
import sys
import threading
import time
import uuid
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any, Protocol

from harness._cell import Lost, failure_rows, run_cell, warm_up
from harness._grid import CellSpec

Rows = list[dict[str, Any]]
#: What an executor yields for a cell: its record rows, or `Lost`.
Outcome = Rows | Lost

#: Seconds a worker may take, on top of ``timeout``, to start and warm a solver up before a cell starts.
STARTUP_ALLOWANCE = 120.0


class Executor(Protocol):
    """Runs cells and yields each one's outcome (record rows, or `Lost`) as it finishes."""

    def map(self, cells: list[CellSpec]) -> Iterator[tuple[CellSpec, Outcome]]: ...

    def close(self) -> None: ...


def _group(spec: CellSpec) -> tuple[str, int, str]:
    """Cells that share a template and a target rig (and so the worker's caches)."""
    return spec.rig, spec.rig_seed, spec.warp


def _timeout_message(timeout: float) -> str:
    return f"cell exceeded --timeout {timeout:g}s and was stopped"


def _exit_text(code: int) -> str:
    if code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit code {code}"


@dataclass
class _Worker:
    process: subprocess.Popen
    connection: multiprocessing.connection.Connection
    spec: CellSpec | None = None
    deadline: float | None = None
    started: bool = False
    group: tuple[str, int, str] | None = None


class LocalExecutor:
    """Cells in ``jobs`` local worker processes (reused; replaced after a timeout or a crash).

    A worker keeps to one rig group (rig, seed, warp) while cells of it are queued and workers spread over
    different groups, so that each worker's rig and transfer caches (`harness._cell`) are reused.

    Parameters
    ----------
    jobs : int
        Number of worker processes, >= 1.
    timeout : float, optional
        Seconds a cell may run (after its warm-up) before its process is killed.
    """

    def __init__(self, jobs: int = 1, timeout: float | None = None) -> None:
        if jobs < 1:
            raise ValueError(f"--jobs must be at least 1, got {jobs}")
        self.jobs = jobs
        self.timeout = timeout
        self._workers: list[_Worker] = []

    def _start_worker(self) -> _Worker:
        mine, theirs = socket.socketpair()
        with mine, theirs:
            process = subprocess.Popen(
                [sys.executable, "-m", "harness._worker", str(theirs.fileno()), str(os.getpid())],
                pass_fds=[theirs.fileno()],
                env={**os.environ, "PYTHONPATH": os.pathsep.join(path for path in sys.path if path)},
                stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL,
                start_new_session=True,  # Ctrl-C reaches the parent only; it stops the workers
            )
            worker = _Worker(process, multiprocessing.connection.Connection(mine.detach()))
        self._workers.append(worker)
        return worker

    def _stop_worker(self, worker: _Worker) -> None:
        if worker.process.poll() is None:
            worker.process.kill()
        worker.process.wait()
        worker.connection.close()
        self._workers.remove(worker)

    def map(self, cells: list[CellSpec]) -> Iterator[tuple[CellSpec, Outcome]]:
        """Run the cells; yield ``(spec, outcome)`` in completion order."""
        queue = list(cells)
        while queue or any(worker.spec is not None for worker in self._workers):
            self._assign(queue)
            busy = [worker for worker in self._workers if worker.spec is not None]
            waitables = [w.connection for w in busy]  # a dying worker closes its end: readable, EOF
            deadlines = [w.deadline for w in busy if w.deadline is not None]
            wait = max(0.0, min(deadlines) - time.monotonic()) if deadlines else None
            ready = set(multiprocessing.connection.wait(waitables, timeout=wait))
            for worker in busy:
                finished = self._poll(worker, ready)
                if finished is not None:
                    yield finished

    def _assign(self, queue: list[CellSpec]) -> None:
        for worker in [w for w in self._workers if w.spec is None and w.process.poll() is not None]:
            self._stop_worker(worker)  # died while idle
        idle = [worker for worker in self._workers if worker.spec is None]
        while queue and (idle or len(self._workers) < self.jobs):
            worker = idle.pop() if idle else self._start_worker()
            spec = queue.pop(self._choose(worker, queue))
            worker.spec, worker.started, worker.group = spec, False, _group(spec)
            worker.deadline = (
                None if self.timeout is None else time.monotonic() + self.timeout + STARTUP_ALLOWANCE
            )
            try:
                worker.connection.send(spec.to_dict())
            except OSError:  # it died since the check; the cell goes back to the queue
                worker.spec = None
                self._stop_worker(worker)
                queue.insert(0, spec)

    def _choose(self, worker: _Worker, queue: list[CellSpec]) -> int:
        """Index of the queued cell for ``worker``: one of the rig group it ran last (its rigs and transfer
        results are cached there), else one of a group no other worker is on, else the first."""
        others = {w.group for w in self._workers if w is not worker}
        for wanted in (lambda group: group == worker.group, lambda group: group not in others):
            for index, spec in enumerate(queue):
                if wanted(_group(spec)):
                    return index
        return 0

    def _poll(self, worker: _Worker, ready: set[Any]) -> tuple[CellSpec, Outcome] | None:
        spec = worker.spec
        assert spec is not None
        while worker.connection in ready or worker.connection.poll():
            ready.discard(worker.connection)
            try:
                message = worker.connection.recv()
            except (EOFError, OSError):
                break
            if message[0] == "started":
                worker.started = True
                worker.deadline = None if self.timeout is None else time.monotonic() + self.timeout
            else:
                worker.spec, worker.deadline = None, None
                return spec, message[2]
        if worker.process.poll() is not None:
            code, pid = worker.process.returncode, worker.process.pid
            self._stop_worker(worker)
            return spec, Lost(f"worker process {pid} died ({_exit_text(code)}) while running the cell")
        if worker.deadline is not None and time.monotonic() >= worker.deadline:
            self._stop_worker(worker)
            if not worker.started:
                allowed = (self.timeout or 0.0) + STARTUP_ALLOWANCE
                return spec, Lost(f"worker start-up and the solver's warm-up took over {allowed:g}s")
            return spec, failure_rows(spec, "timeout", _timeout_message(self.timeout or 0.0))
        return None

    def close(self) -> None:
        """Stop every worker (cells in flight are lost; their part files were never written)."""
        for worker in list(self._workers):
            if worker.spec is None and worker.process.poll() is None:
                try:
                    worker.connection.send(None)
                    worker.process.wait(timeout=2)
                except (OSError, subprocess.TimeoutExpired):
                    pass
            self._stop_worker(worker)


_task_workers = threading.local()


def run_isolated(spec_data: dict[str, Any], timeout: float | None) -> Outcome:
    """Run one cell (given as a dict) to completion; the task function Dask workers execute.

    Without a timeout the cell runs in the calling thread. With one, it runs in a local worker process
    that can be killed; that process is kept per calling thread and reused by later tasks, so warm-up
    and imports are paid once per Dask worker thread, not once per cell.
    """
    spec = CellSpec.from_dict(spec_data)
    if timeout is None:
        warm_up(spec.solver)
        return run_cell(spec)
    executor = getattr(_task_workers, "executor", None)
    if executor is None:
        executor = _task_workers.executor = LocalExecutor(jobs=1, timeout=timeout)
    executor.timeout = timeout
    return [outcome for _, outcome in executor.map([spec])][0]


class DaskExecutor:
    """Cells as tasks on a Dask distributed cluster (``tcp://HOST:PORT``), one task per cell.

    Records are identical to the local executor's (the same `run_cell` produces them); with a timeout,
    each task runs its cell in a local worker process that can be stopped (see `run_isolated`). A task that
    fails is `Lost`: `run_cell` turns every failure of the cell itself into rows, so an exception here
    comes from the cluster (a lost scheduler cancels every task at once).
    """

    def __init__(self, scheduler: str, timeout: float | None = None) -> None:
        try:
            from distributed import Client
        except ImportError as error:
            raise ValueError(
                "--executor dask needs the 'distributed' package: "
                "pip install 'expression-packing-harness[dask]'"
            ) from error
        try:
            self._client = Client(scheduler, timeout="10s")
        except (OSError, TimeoutError) as error:
            raise ValueError(f"cannot reach the Dask scheduler at {scheduler}: {error}") from error
        self.timeout = timeout
        self._futures: list[Any] = []

    def map(self, cells: list[CellSpec]) -> Iterator[tuple[CellSpec, Outcome]]:
        """Submit every cell; yield ``(spec, outcome)`` in completion order."""
        from distributed import as_completed

        run = uuid.uuid4().hex[:8]
        by_key = {}
        for spec in cells:
            future = self._client.submit(
                run_isolated, spec.to_dict(), self.timeout, key=f"harness-cell-{spec.id}-{run}", pure=False
            )
            by_key[future.key] = spec
            self._futures.append(future)
        for future in as_completed(self._futures):
            spec = by_key[future.key]
            try:
                outcome = future.result()
            except Exception as error:  # noqa: BLE001 - no result of the cell: --resume runs it again
                outcome = Lost(_dask_failure(error))
            yield spec, outcome
        self._futures.clear()

    def close(self) -> None:
        """Cancel unfinished tasks and disconnect from the scheduler (quietly, if it is gone: the lost
        cells already say so, a traceback from the client's reconnection attempts would add nothing)."""
        client_log = logging.getLogger("distributed.client")
        level = client_log.level
        client_log.setLevel(logging.CRITICAL)
        try:
            if self._futures:
                self._client.cancel(self._futures)
        finally:
            try:
                self._client.close(timeout=10)
            finally:
                client_log.setLevel(level)


def _dask_failure(error: Exception) -> str:
    """One line on a failed Dask task: the cancellation reason (e.g. ``scheduler-connection-lost``), or
    the exception's type and first line."""
    reason = getattr(error, "reason", None)
    if isinstance(reason, str) and reason:
        return f"Dask task cancelled ({reason})"
    lines = [line.strip() for line in str(error).splitlines() if line.strip()]
    return f"Dask task failed ({type(error).__name__}{': ' + lines[0] if lines else ''})"
