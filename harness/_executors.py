"""Executors: where cells run. Local worker processes (the default) or a Dask distributed cluster.

Both hand every cell to `harness._cell.run_cell` in a process of their own and yield ``(spec, outcome)`` as
cells finish, in completion order; the caller writes the rows. Every cell ends as a result, but for what
the infrastructure loses:

- a cell, or its solver's warm-up, that exceeds ``timeout`` seconds is stopped by killing its process and
  yields its ``timeout`` cell row with the ``expression`` rows it had finished (the cell appends each to a
  journal file as it goes, `harness._journal`, read after the kill; its sequence is cut there, unchecked
  and without transfers);
- a worker process that dies (a segfault, an abort, a kill) or fails while warming up or running the cell
  yields `harness._cell.Lost` with ``crash`` set (how the process ended): the run counts the crashes of
  each cell and records one that crashed twice ``crashed`` (`harness._run`);
- what is no result of the cell yields `harness._cell.Lost` alone, and ``--resume`` runs the cell again: a
  worker process that does not start within `STARTUP_ALLOWANCE`, a Dask task that fails (scheduler or
  worker lost, a cell a Dask worker cannot set up: `harness._cell.CellSetupError`).

Local workers are `solvers.Worker` processes (fresh interpreters that end with the process that started
them, even when it is killed with ``kill -9``), reused from cell to cell. A cell is three calls sent
together: `harness._cell.started` (the reply says the process has started and imported the harness),
`harness._cell.warm_up` (one unrecorded solve per solver and process), then `harness._cell.run_cell`.
Start-up may take `STARTUP_ALLOWANCE` seconds; the warm-up then gets ``timeout``, and the cell the full
``timeout`` again.

On a Dask cluster (one given by its scheduler's address, or a `distributed.LocalCluster` started for the
run) the rig files stay where the harness runs: the harness reads each rig once and scatters its content to
the cluster (`DaskExecutor`), so a worker never opens a path it may not have (a relative path, a rig fetched
into the harness machine's cache). Both executors keep a worker on one rig group while it has cells queued
(`_next_cell`), so that its rig and transfer caches are reused.
"""

from __future__ import annotations

import logging
import threading
import time
import uuid
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, cast

from harness._cell import Lost, run_cell, set_up, timeout_rows, warm_up
from harness._cell_rigs import TemplateKey, generated, template_key, verified_template
from harness._grid import CellSpec
from harness._journal import SEQUENCE_END, new_journal, read_journal, remove_journal, remove_orphaned_journals
from registry import HarnessError
from solvers import Worker, WorkerDied, WorkerError, wait_for_workers

if TYPE_CHECKING:
    from distributed import Future, LocalCluster

    from rigs import Rig

Rows = list[dict[str, Any]]
#: What an executor yields for a cell: its record rows, or `Lost`.
Outcome = Rows | Lost
#: Cells of one rig group share a template and a target rig: (rig, seed, warp).
Group = tuple[str, int, str]

#: Seconds a worker process may take to start (a fresh interpreter importing the harness) before a cell's
#: warm-up begins: longer is the machine's trouble, not the cell's, and the cell is lost.
STARTUP_ALLOWANCE = 120.0

#: What a busy worker is doing for its cell, in order (one reply ends each).
_PHASES = ("starting", "warming up", "running")

#: Seconds between looks at a Dask cluster's workers while none is idle (a worker that joins the cluster
#: gets cells within this time).
_POLL = 1.0
#: Seconds a Dask cluster may have no worker at all before the run gives up on the cells left (batch
#: workers may wait in a queue): they are lost, and ``--resume`` runs them.
WORKER_WAIT = 600.0


class Executor(Protocol):
    """Runs cells and yields each one's outcome (record rows, or `Lost`) as it finishes."""

    def map(self, cells: list[CellSpec]) -> Iterator[tuple[CellSpec, Outcome]]: ...

    def close(self) -> None: ...


def _group(spec: CellSpec) -> Group:
    """Cells that share a template and a target rig (and so the worker's caches)."""
    return spec.rig, spec.rig_seed, spec.warp


def _next_cell(last: Group | None, others: set[Group | None], queue: list[CellSpec]) -> int:
    """Index of the queued cell for a worker whose last cell was of rig group ``last``: one of that group
    (its rigs and transfer results are cached there), else one of a group no other worker is on
    (``others``: the groups the other workers run or ran last), else the first."""
    for wanted in (lambda group: group == last, lambda group: group not in others):
        for index, spec in enumerate(queue):
            if wanted(_group(spec)):
                return index
    return 0


def _timeout_message(timeout: float, finished: int, whole: bool) -> str:
    """The message of a cell stopped after ``finished`` expressions (``whole``: its sequence had ended)."""
    stopped = f"cell exceeded --timeout {timeout:g}s and was stopped"
    if not finished:
        return f"{stopped} before its first expression was finished"
    count = f"{finished} expression{'s' if finished > 1 else ''}"
    if whole:
        return f"{stopped} after its whole sequence of {count}, while checking or transferring (no transfers)"
    return f"{stopped} after {count} (the sequence was cut there: not checked, no transfers)"


def _warm_up_message(timeout: float) -> str:
    """The message of a cell whose solver's warm-up was stopped."""
    return (
        f"the solver's warm-up (one unrecorded solve of a tiny problem, before the cell) exceeded --timeout "
        f"{timeout:g}s and was stopped; the cell did not start"
    )


@dataclass
class _Slot:
    """One of the executor's worker processes and the cell it runs (``spec`` and ``journal`` are None
    while it is idle; ``phase`` indexes `_PHASES`)."""

    worker: Worker = field(default_factory=lambda: Worker("harness cell", log=False))
    spec: CellSpec | None = None
    journal: Path | None = None
    deadline: float | None = None
    phase: int = 0
    group: Group | None = None


class LocalExecutor:
    """Cells in ``jobs`` local worker processes (reused; replaced after a timeout or a crash).

    A worker keeps to one rig group (rig, seed, warp) while cells of it are queued and workers spread over
    different groups, so that each worker's rig and transfer caches (`harness._cell`) are reused.

    Parameters
    ----------
    jobs : int
        Number of worker processes, >= 1.
    timeout : float, optional
        Seconds the solver's warm-up may take, and then the cell, before its process is killed.

    Attributes
    ----------
    templates : dict
        Template rigs by `harness._cell_rigs.template_key`, sent to the workers with each cell of that rig
        instead of its path (a Dask worker's cells: the rig was read where the harness runs).
    """

    def __init__(self, jobs: int = 1, timeout: float | None = None) -> None:
        if jobs < 1:
            raise HarnessError(f"--jobs must be at least 1, got {jobs}")
        self.jobs = jobs
        self.timeout = timeout
        self.templates: dict[TemplateKey, Rig] = {}
        self._slots = [_Slot() for _ in range(jobs)]
        remove_orphaned_journals()  # (left by a harness killed outright on this machine)

    def map(self, cells: list[CellSpec]) -> Iterator[tuple[CellSpec, Outcome]]:
        """Run the cells; yield ``(spec, outcome)`` in completion order."""
        queue = list(cells)
        while queue or any(slot.spec is not None for slot in self._slots):
            self._assign(queue)
            busy = [slot for slot in self._slots if slot.spec is not None]
            deadlines = [slot.deadline for slot in busy if slot.deadline is not None]
            wait_for_workers(
                [slot.worker for slot in busy],
                timeout=max(0.0, min(deadlines) - time.monotonic()) if deadlines else None,
            )
            for slot in busy:
                outcome = self._outcome(slot)
                if outcome is not None:
                    spec, slot.spec, slot.deadline = slot.spec, None, None
                    assert spec is not None and slot.journal is not None
                    remove_journal(slot.journal)
                    slot.journal = None
                    yield spec, outcome

    def _assign(self, queue: list[CellSpec]) -> None:
        """Send queued cells to idle workers (one that ended while idle is started again)."""
        idle = [slot for slot in self._slots if slot.spec is None]
        while queue and idle:
            slot = idle[-1]
            spec = queue.pop(self._choose(slot, queue))
            journal = new_journal()
            try:
                slot.worker.send("harness._cell:started")
                slot.worker.send("harness._cell:warm_up", spec.solver, spec.time_limit)
                template = self.templates.get(template_key(spec))
                slot.worker.send("harness._cell:run_cell", spec, str(journal), template)
            except WorkerDied:  # it ended since it was started: the cell goes back, a fresh process takes it
                remove_journal(journal)
                queue.insert(0, spec)
                continue
            idle.pop()
            slot.spec, slot.journal, slot.phase, slot.group = spec, journal, 0, _group(spec)
            slot.deadline = None if self.timeout is None else time.monotonic() + STARTUP_ALLOWANCE

    def _choose(self, slot: _Slot, queue: list[CellSpec]) -> int:
        """Index of the queued cell for ``slot`` (`_next_cell`)."""
        return _next_cell(slot.group, {other.group for other in self._slots if other is not slot}, queue)

    def _outcome(self, slot: _Slot) -> Outcome | None:
        """The outcome of a busy slot's cell once its worker replied, ended or passed its deadline."""
        assert slot.spec is not None and slot.journal is not None
        try:
            while slot.worker.pending and slot.worker.ready():
                reply = slot.worker.receive()
                if _PHASES[slot.phase] == "running":
                    return cast(Outcome, reply)
                slot.phase += 1  # started, or warmed up: the next phase gets the full timeout
                slot.deadline = None if self.timeout is None else time.monotonic() + self.timeout
        except WorkerDied as died:
            self._discard(slot)
            return self._crash(slot, f"worker process {died.pid} died ({died.exit})", died.exit)
        except WorkerError as error:
            self._discard(slot)
            raised = str(error).splitlines()[-1]
            return self._crash(slot, f"worker process failed: {raised}", raised)
        if slot.deadline is None or time.monotonic() < slot.deadline:
            return None
        self._discard(slot)
        timeout = self.timeout or 0.0
        if _PHASES[slot.phase] == "starting":
            return Lost(f"worker start-up took over {STARTUP_ALLOWANCE:g}s")
        if _PHASES[slot.phase] == "warming up":
            return timeout_rows(slot.spec, [], _warm_up_message(timeout), timeout=timeout, whole=False)
        journal = read_journal(slot.journal)
        finished = [row for row in journal if row.get("kind") == "expression"]
        whole = any(row.get("kind") == SEQUENCE_END for row in journal)
        message = _timeout_message(timeout, len(finished), whole)
        return timeout_rows(slot.spec, finished, message, timeout=timeout, whole=whole)

    @staticmethod
    def _crash(slot: _Slot, what: str, how: str) -> Lost:
        """A slot's worker ended or failed: a crash of the cell (``how``) once the process had started."""
        phase = _PHASES[slot.phase]
        reason = f"{what} while {'running the cell' if phase == 'running' else phase}"
        return Lost(reason) if phase == "starting" else Lost(reason, crash=how)

    @staticmethod
    def _discard(slot: _Slot) -> None:
        """Stop a slot's worker (the next cell starts a fresh one, with empty caches)."""
        slot.worker.stop()
        slot.group = None

    def close(self) -> None:
        """Stop every worker (cells in flight are lost; their part files were never written)."""
        for slot in self._slots:
            slot.worker.stop()
            if slot.journal is not None:
                remove_journal(slot.journal)
            slot.spec, slot.journal = None, None


_task_workers = threading.local()


def run_isolated(spec_data: dict[str, Any], timeout: float | None, template: Rig | None = None) -> Outcome:
    """Run one cell (given as a dict) to completion; the task function Dask workers execute.

    ``template`` is the cell's template rig as the harness read it (None for a generated rig, built here).
    The cell is first set up here (`harness._cell.set_up`: its rigs and plugins), so that a cell this
    machine cannot run fails the task (it is lost, never an ``error`` row). Without a timeout the cell
    runs in the calling thread. With one, it runs in a local worker process that can be killed; that
    process is kept per calling thread and reused by later tasks, so warm-up and imports are paid once
    per Dask worker thread, not once per cell.

    Raises
    ------
    harness._cell.CellSetupError
        When the cell cannot be set up on this machine.
    """
    spec = CellSpec.from_dict(spec_data)
    set_up(spec, template)
    if timeout is None:
        warm_up(spec.solver, spec.time_limit)
        return run_cell(spec, None, template)
    executor = getattr(_task_workers, "executor", None)
    if executor is None:
        executor = _task_workers.executor = LocalExecutor(jobs=1, timeout=timeout)
    executor.timeout = timeout
    executor.templates = {} if template is None else {template_key(spec): template}
    return [outcome for _, outcome in executor.map([spec])][0]


@dataclass
class _DaskSlot:
    """One thread of a Dask worker (``address``): the rig group of its last cell and the cell it runs
    (None while idle)."""

    address: str
    group: Group | None = None
    spec: CellSpec | None = None


class DaskExecutor:
    """Cells as tasks on a Dask distributed cluster, one task per cell: the cluster at ``scheduler``
    (``tcp://HOST:PORT``), or a `distributed.LocalCluster` of ``jobs`` worker processes of one thread
    each, started here and closed with the executor.

    Records are identical to the local executor's (the same `run_cell` produces them); with a timeout,
    each task runs its cell in a local worker process that can be stopped (see `run_isolated`), and a cell
    stopped there keeps the expressions it finished, as with `LocalExecutor` (its journal is a file on the
    Dask worker's machine, read there). A rig read from files is read here once, checked against the
    cells' digest and scattered to the cluster: the tasks receive its content, never its path. A task that
    fails is `Lost`: `run_cell` turns every failure of the cell itself into rows, so an exception here
    comes from the cluster (a lost scheduler cancels every task at once) or from a worker that cannot set
    the cell up; a task that killed its Dask workers (``KilledWorker``) is a crash of the cell.

    Cells are handed out as the local executor hands them to its processes: one per idle worker thread,
    chosen by `_next_cell` so that a Dask worker keeps to one rig group and its caches are reused, and
    submitted to that worker (another one takes it if that worker leaves the cluster). Workers that join
    the cluster during the run get cells within `_POLL` seconds.

    Parameters
    ----------
    scheduler : str, optional
        Address of the scheduler of a running cluster; None starts a cluster here (`_local_cluster`).
    timeout : float, optional
        Seconds the solver's warm-up may take, and then the cell, before its process is killed.
    jobs : int
        Worker processes of the cluster started here (without ``scheduler``), >= 1.
    worker_wait : float
        Seconds the cluster may have no worker before the cells left are lost (`WORKER_WAIT`).
    notice : callable, optional
        Told, in one line, when the executor starts waiting for a worker to join.
    """

    def __init__(
        self,
        scheduler: str | None = None,
        timeout: float | None = None,
        jobs: int = 1,
        *,
        worker_wait: float = WORKER_WAIT,
        notice: Callable[[str], None] | None = None,
    ) -> None:
        try:
            from distributed import Client
        except ImportError as error:
            raise HarnessError(
                "--executor dask needs the 'distributed' package: "
                "pip install 'expression-packing-harness[dask]'"
            ) from error
        self._cluster = None if scheduler else _local_cluster(jobs)
        try:
            self._client = Client(scheduler or self._cluster, timeout="10s")
        except (OSError, TimeoutError, ValueError) as error:  # (ValueError: a malformed address)
            if self._cluster is not None:
                self._cluster.close()
            where = f"--scheduler {scheduler}" if scheduler else "the local Dask cluster"
            raise HarnessError(f"{where}: cannot reach the Dask scheduler: {error}") from error
        self.timeout = timeout
        self.where = f"the Dask cluster at {scheduler}" if scheduler else "the local Dask cluster"
        self.worker_wait = worker_wait
        self.notice = notice or (lambda message: None)
        self._slots: list[_DaskSlot] = []
        self._running: dict[Future, _DaskSlot] = {}

    def map(self, cells: list[CellSpec]) -> Iterator[tuple[CellSpec, Outcome]]:
        """Run the cells; yield ``(spec, outcome)`` in completion order. When the scheduler is lost, the
        cells not yet sent are lost with the tasks it cancelled."""
        run = uuid.uuid4().hex[:8]
        templates: dict[TemplateKey, Future | Lost | None] = {}
        queue = []
        for spec in cells:
            key = template_key(spec)
            if key not in templates:
                templates[key] = self._scattered(spec)
            template = templates[key]
            if isinstance(template, Lost):
                yield spec, template
            else:
                queue.append(spec)
        alone_since = None  # (when the cluster was last seen without a worker)
        while queue or self._running:
            cluster_lost = None
            if queue:
                try:
                    self._hand_out(queue, templates, run)
                except OSError as error:  # the scheduler went away between two cells
                    cluster_lost = Lost(f"Dask scheduler lost: {error}")
            if not self._running and cluster_lost is None:  # no worker yet: wait for one to join
                if self._slots:
                    alone_since = None
                elif alone_since is None:
                    alone_since = time.monotonic()
                    self.notice(
                        f"waiting for a worker to join {self.where} (it has none; giving up after "
                        f"{self.worker_wait:g}s)"
                    )
                elif time.monotonic() - alone_since > self.worker_wait:
                    lost = Lost(f"no worker joined {self.where} within {self.worker_wait:g}s")
                    yield from ((spec, lost) for spec in queue)
                    queue.clear()
                    continue
                time.sleep(_POLL)
                continue
            for future in self._finished():
                slot = self._running.pop(future)
                spec, slot.spec = slot.spec, None
                assert spec is not None
                try:
                    outcome = future.result()
                except Exception as error:  # noqa: BLE001 - no result of the cell: --resume runs it again
                    outcome = _dask_failure(error)
                    if self._client.status != "running":
                        cluster_lost = outcome
                yield spec, outcome
            if cluster_lost is not None:
                yield from ((spec, cluster_lost) for spec in queue)
                queue.clear()

    def _hand_out(
        self, queue: list[CellSpec], templates: dict[TemplateKey, Future | Lost | None], run: str
    ) -> None:
        """Submit a queued cell to every idle worker thread of the cluster."""
        self._follow_workers()
        for slot in [slot for slot in self._slots if slot.spec is None]:
            if queue:
                self._submit(slot, queue, templates, run)

    def _finished(self) -> list[Future]:
        """The running tasks that have ended (finished, failed or cancelled), after waiting up to `_POLL`
        seconds for the first."""
        from distributed import wait
        from distributed.client import FuturesCancelledError

        try:
            wait(list(self._running), timeout=_POLL, return_when="FIRST_COMPLETED")
        except (TimeoutError, FuturesCancelledError):  # none ended yet, or one was cancelled
            pass
        return [future for future in self._running if future.done()]

    def _follow_workers(self) -> None:
        """One slot per thread of every worker in the cluster now; a departed worker's busy slots stay
        until their cells end (the scheduler gives those to another worker)."""
        threads = self._client.nthreads()
        self._slots = [slot for slot in self._slots if slot.address in threads or slot.spec is not None]
        for address, count in threads.items():
            have = sum(slot.address == address for slot in self._slots)
            self._slots += [_DaskSlot(address) for _ in range(count - have)]

    def _submit(
        self,
        slot: _DaskSlot,
        queue: list[CellSpec],
        templates: dict[TemplateKey, Future | Lost | None],
        run: str,
    ) -> None:
        """Submit the queued cell `_next_cell` chooses for an idle slot, to the slot's worker."""
        others = {other.group for other in self._slots if other is not slot}
        spec = queue.pop(_next_cell(slot.group, others, queue))
        future = self._client.submit(
            run_isolated,
            spec.to_dict(),
            self.timeout,
            templates[template_key(spec)],
            key=f"harness-cell-{spec.id}-{run}",
            pure=False,
            workers=[slot.address],
            allow_other_workers=True,
        )
        slot.spec, slot.group = spec, _group(spec)
        self._running[future] = slot

    def _scattered(self, spec: CellSpec) -> Future | Lost | None:
        """The cluster's copy of a cell's template rig, read here (None for a generated rig, which the
        workers build themselves), or `Lost` when it cannot be read or changed since the run started."""
        if generated(spec):
            return None
        try:
            return self._client.scatter(verified_template(spec), hash=False)
        except Exception as error:  # noqa: BLE001 - every cell of the rig is lost, the reason says why
            return Lost(f"rig {spec.rig} cannot be sent to the cluster: {error}")

    def close(self) -> None:
        """Cancel unfinished tasks and disconnect from the scheduler (quietly, if it is gone: the lost
        cells already say so, a traceback from the client's reconnection attempts would add nothing);
        stop the local cluster if this executor started one."""
        client_log = logging.getLogger("distributed.client")
        level = client_log.level
        client_log.setLevel(logging.CRITICAL)
        try:
            if self._running:
                self._client.cancel(list(self._running))
                self._running.clear()
        finally:
            try:
                self._client.close(timeout=10)
            finally:
                client_log.setLevel(level)
                if self._cluster is not None:
                    self._cluster.close(timeout=10)


def _local_cluster(jobs: int) -> LocalCluster:
    """A Dask cluster on this machine for one run: ``jobs`` worker processes of one thread each, as many
    as the local executor's, in the same environment (Dask's nanny would otherwise start them with its
    ``pre-spawn-environ``: ``MALLOC_TRIM_THRESHOLD_`` makes cells a quarter slower, and one BLAS thread),
    without a memory limit (as the local executor's processes) or dashboard."""
    import dask
    from distributed import LocalCluster

    if jobs < 1:
        raise HarnessError(f"--jobs must be at least 1, got {jobs}")
    try:
        with dask.config.set({"distributed.nanny.pre-spawn-environ": {}}):
            return LocalCluster(
                n_workers=jobs,
                threads_per_worker=1,
                processes=True,
                memory_limit=0,
                silence_logs=logging.ERROR,
                scheduler_kwargs={"dashboard": False, "dashboard_address": ":0"},  # (its HTTP server)
            )
    except (OSError, TimeoutError) as error:
        raise HarnessError(f"cannot start a local Dask cluster of {jobs} workers: {error}") from error


def _dask_failure(error: Exception) -> Lost:
    """A failed Dask task, in one line: the cancellation reason (e.g. ``scheduler-connection-lost``), or
    the exception's type and first line; a task that killed the Dask workers running it is a crash."""
    from distributed import KilledWorker

    reason = getattr(error, "reason", None)
    if isinstance(reason, str) and reason:
        return Lost(f"Dask task cancelled ({reason})")
    lines = [line.strip() for line in str(error).splitlines() if line.strip()]
    described = f"{type(error).__name__}{': ' + lines[0] if lines else ''}"
    if isinstance(error, KilledWorker):
        return Lost(f"Dask task failed ({described})", crash="its Dask workers died running it")
    return Lost(f"Dask task failed ({described})")
