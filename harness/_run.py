"""A run: the grid of a `RunConfig` executed cell by cell into ``OUT/``, resumable after any interruption.

``OUT/run.json`` holds (keys in order):

- ``format`` (2), ``state`` (``running``, ``complete``, ``incomplete`` (cells were lost, see below),
  ``interrupted`` or ``failed``), ``command`` (argv),
- ``config``: the exact `RunConfig` (``--solvers all`` already expanded to names),
- ``n_cells``: size of the grid, ``rig_digests``: the content digest of every rig
  (`harness._grid.rig_digest`; the cell ids hash them), ``rig_inputs``: per rig file or folder, what its
  read opened (`rigs.RigInputs`: each file's SHA-256 and each folder listing), so that a resume names the
  file that changed,
- ``versions``: Python and distributions (`harness._environment.DISTRIBUTIONS`), plus ``solvers`` and
  ``transfers``: per plugin ``available``, ``reason``, ``version``; ``--resume`` refuses a run whose
  options, rig content or any of these versions changed (`harness._resume`),
- ``git`` (``commit``, ``dirty``), ``machine`` (``hostname``, ``platform``, ``processor``, ``cpu_count``),
- ``execution``: how the cells ran last (``executor`` and ``jobs`` or ``scheduler``; ``pid`` and ``host`` of
  the harness process),
- ``started``, ``finished`` (ISO 8601, UTC; ``finished`` is null until the run ends), ``resumed`` (list of
  the times ``--resume`` continued it), ``error`` (the message of a ``failed`` run), ``lost`` (cell id ->
  ``{"cell": label, "reason": ...}`` for the cells the infrastructure lost in the last session),
  ``crashes`` (cell id -> ``{"cell": label, "count": n, "exit": how}``: how often, over every session, the
  worker process died or failed running a cell that has no part file yet).

Cells run on an executor (`harness._executors`); each finished cell's rows are checked again in this process
(`harness._verify`: a worker runs the solver plugin, which may change anything there) and written at once as
its own part file (`harness._records`), so an interruption loses only the cells in flight. A cell lost to the
infrastructure (a killed worker, a lost Dask scheduler) gets no part file: the run ends ``incomplete`` and
``--resume`` runs exactly the cells without a complete part file. A worker process that crashes on a cell
loses it the first time and records it ``crashed`` the second (`harness._failures`). ``--resume`` runs no cell
that has a part file; with ``retry_failed`` (``--retry-failed``) it also runs again the cells recorded
`harness._failures.RETRIED_STATUSES`, whose result then replaces the recorded one. ``--resume`` first reads
every part back and sets broken ones aside, refuses options that differ from ``run.json`` and rigs whose
content changed, and like every run holds an exclusive lock on ``OUT`` (``flock`` on the folder), so two runs
never write one folder. The folder's manifest (`registry.claim`) lists every file the run writes; ``--force``
replaces an earlier run only when the folder holds nothing else, so it never removes a file the harness
did not write.
"""

from __future__ import annotations

import contextlib
import datetime
import fcntl
import itertools
import json
import os
import socket
import sys
import time
import warnings
from collections import Counter
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import rigs
from harness import _environment as environment, _plugins as plugins
from harness._bounds import check_bounds
from harness._cell import Lost, failure_rows
from harness._certificate import INCONSISTENT, certify
from harness._executors import Executor
from harness._failures import count_crash, failed_cells
from harness._grid import NO_WARP, CellSpec, RunConfig, digest_key, rig_digest
from harness._records import (
    RECORDS_DIR,
    open_for_resume,
    open_new,
    part_bytes,
    part_files,
    remove_previous,
    repair_parts,
    write_error,
    write_listed,
)
from harness._resume import options_changed, rigs_changed, versions_changed
from harness._rig_checks import check_rig_files
from harness._rows import Row
from harness._run_file import RUN_FILE, RunDirectoryError, read_run
from harness._verify import CellChecker
from registry import HarnessError, OutputFolder, OutputFolderError, check_apart, stop_signals_deferred

if TYPE_CHECKING:
    from rigs import RigInputs

RUN_FORMAT = 2


class Reporter(Protocol):
    """Receives progress events (the CLI shows them; tests and library callers may ignore them)."""

    def begin(self, total: int, done: int, pending: list[CellSpec], skipped: dict[str, str]) -> None: ...

    def notice(self, message: str) -> None: ...

    def cell_finished(self, spec: CellSpec, rows: list[Row]) -> None: ...

    def cell_lost(self, spec: CellSpec, reason: str) -> None: ...

    def end(self) -> None: ...


class SilentReporter:
    """A `Reporter` that reports nothing."""

    def begin(self, total: int, done: int, pending: list[CellSpec], skipped: dict[str, str]) -> None:
        pass

    def notice(self, message: str) -> None:
        pass

    def cell_finished(self, spec: CellSpec, rows: list[Row]) -> None:
        pass

    def cell_lost(self, spec: CellSpec, reason: str) -> None:
        pass

    def end(self) -> None:
        pass


@dataclass
class RunSummary:
    """What a finished (or resumed) run did.

    ``lost`` maps the id of each cell the infrastructure lost to the reason (the run is then incomplete:
    ``--resume`` runs them again); ``set_aside`` maps each broken part file moved away by ``--resume`` to
    where it went and why.
    """

    out: Path
    total: int
    already_done: int
    statuses: Counter[str] = field(default_factory=Counter)
    seconds: float = 0.0
    lost: dict[str, str] = field(default_factory=dict)
    set_aside: dict[Path, str] = field(default_factory=dict)

    @property
    def complete(self) -> bool:
        """Whether every cell of the grid now has its records."""
        return not self.lost


def now() -> str:
    """Current UTC time, ISO 8601, to the second."""
    return datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")


def validate_config(
    config: RunConfig, constraint_origins: Mapping[tuple[str, str], str] | None = None
) -> RunConfig:
    """Check every name and value of a configuration; expand ``all`` solvers.

    Raises
    ------
    ValueError
        One line naming the option and the bad value, listing the valid ones where there is a list.
    """
    solvers = plugins.expand_names(config.solvers, plugins.solver_names(), "solver", "--solvers")
    transfers = (
        plugins.expand_names(config.transfers, plugins.transfer_names(), "transfer", "--transfers")
        if config.transfers
        else ()
    )
    plugins.check_rigs(config.rigs)
    plugins.check_warps(config.warps)
    check_bounds(config.with_overrides(solvers=solvers))
    if config.repetitions < 1:
        raise HarnessError(f"--repetitions must be at least 1, got {config.repetitions}")
    if config.jmax is not None and config.jmax < 1:
        raise HarnessError(f"--jmax must be at least 1, got {config.jmax}")
    if any(j < 1 for j in config.j_values):
        raise HarnessError(f"--j-values must be positive integers, got {list(config.j_values)}")
    _check_packing_params(config, constraint_origins or {})
    plugins.check_settings(solvers, transfers)
    for option, value in (("--time-limit", config.time_limit), ("--timeout", config.timeout)):
        if value is not None and value <= 0:
            raise HarnessError(f"{option} must be positive, got {value}")
    return config.with_overrides(solvers=solvers, transfers=transfers)


def _check_packing_params(config: RunConfig, constraint_origins: Mapping[tuple[str, str], str]) -> None:
    """Let `packing.PackingParams` judge every value of the packing axes (it names the bad one), and let
    `packing.analyse` judge the artist constraints and regions on every rig, before any cell runs; a pair
    of a constraints file (``constraint_origins``: pair -> file) naming a shape a rig lacks is told naming
    the file (`harness.check_file_pairs`)."""
    import packing

    for values in itertools.product(config.mu, config.alpha, config.beta, config.cap, config.distortion):
        mu, alpha, beta, cap, distortion = values
        packing.PackingParams(mu=mu, alpha=alpha, beta=beta, max_per_expression=cap, distortion=distortion)
    if not (config.together or config.apart or config.regions):
        return
    import rigs
    from harness._cell_rigs import packing_params
    from harness._cli_constraints import check_file_pairs

    options = [name for name in ("together", "apart", "regions") if getattr(config, name)]
    given = " ".join(f"--{name}" for name in options)
    spec = config.cells()[0]
    for argument in config.rigs:
        rig = rigs.resolve(argument, seed=config.seed[0])
        check_file_pairs(rig, {"together": config.together, "apart": config.apart}, constraint_origins)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                packing.analyse(rig, None, **packing_params(spec))
        except ValueError as error:
            raise HarnessError(f"{given} on rig {argument}: {error}") from None


def previous_run(out: Path, *, resume: bool, force: bool) -> dict[str, Any] | None:
    """The ``run.json`` to continue when resuming, else None; nothing on disk changes here.

    Raises
    ------
    RunDirectoryError
        When ``out`` holds another run and neither ``resume`` nor ``force`` is given, or when there is
        nothing to resume.
    """
    out = Path(out)
    if resume and force:
        raise RunDirectoryError("give either --resume (finish the run) or --force (replace it), not both")
    if resume:
        if not (out / RUN_FILE).is_file():
            raise RunDirectoryError(
                f"{out} holds no run to resume (no {RUN_FILE}); start one without --resume"
            )
        return read_run(out)
    if ((out / RUN_FILE).exists() or part_files(out)) and not force:
        raise RunDirectoryError(
            f"{out} already holds a run; use --resume to finish it, --force to overwrite it, "
            "or choose another --out"
        )
    return None


def refuse_changes(out: Path, changes: list[str]) -> None:
    """Refuse to resume a run whose options, rigs or versions changed (`harness._resume`).

    Raises
    ------
    RunDirectoryError
        Listing every change.
    """
    if changes:
        raise RunDirectoryError(
            f"--resume {out}: differs from its {RUN_FILE}: {'; '.join(changes)}; restore them to finish the "
            "run as it was started, or start a new run with --force or another --out"
        )


def current_versions(config: RunConfig) -> dict[str, Any]:
    """``run.json``'s ``versions``: Python and the key distributions, and every solver and transfer of
    ``config`` as ``harness list`` shows it."""
    return {
        **environment.versions(),
        "solvers": {name: plugins.listing(plugins.solver_info(name)) for name in config.solvers},
        "transfers": {name: plugins.listing(plugins.transfer_info(name)) for name in config.transfers},
    }


def _check_apart_from_rigs(out: Path, arguments: tuple[str, ...]) -> None:
    """The run folder may not be a rig's file or folder or lie inside a rig folder (its content would
    change as the run writes)."""
    try:
        check_apart(out, [path for argument in arguments for path in rigs.argument_paths(argument)])
    except OutputFolderError as error:
        raise RunDirectoryError(f"--out {error}") from None


@contextlib.contextmanager
def locked(out: Path) -> Iterator[None]:
    """Hold an exclusive lock on the run folder ``out`` (``flock`` on the folder itself, released when
    the process ends, however it ends), so that two runs never write one folder.

    Raises
    ------
    RunDirectoryError
        When another process holds it (naming the holder ``run.json`` records).
    """
    descriptor = os.open(out, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    try:
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = _holder(out)
            raise RunDirectoryError(
                f"{out} is in use by another harness run{holder}; wait for it to end, or choose another --out"
            ) from None
        except OSError as error:
            raise RunDirectoryError(f"{out}: cannot lock the folder ({error.strerror or error})") from None
        yield
    finally:
        os.close(descriptor)


def in_progress(out: str | Path) -> bool:
    """Whether a harness run holds the run folder ``out`` now (the lock of `locked`, taken for a moment as a
    shared one to see: a run starting in that moment is told the folder is in use)."""
    try:
        descriptor = os.open(out, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except OSError:
        return False
    try:
        fcntl.flock(descriptor, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    except OSError:
        return False
    finally:
        os.close(descriptor)  # (releases the shared lock)
    return False


def _holder(out: Path) -> str:
    try:
        execution = read_run(out).get("execution") or {}
    except (OSError, ValueError):
        return ""
    if "pid" not in execution:
        return ""
    return f" (pid {execution['pid']} on {execution.get('host', '?')})"


def run_grid(
    config: RunConfig | None,
    out: str | Path,
    *,
    make_executor: Callable[[float | None], Executor],
    resume: bool = False,
    force: bool = False,
    reporter: Reporter | None = None,
    command: list[str] | None = None,
    execution: dict[str, Any] | None = None,
    retry_failed: bool = False,
    constraint_origins: Mapping[tuple[str, str], str] | None = None,
) -> RunSummary:
    """Run (or resume) a grid into ``out``.

    Parameters
    ----------
    config : RunConfig or None
        The grid. When ``resume`` is true, None means the configuration stored in ``run.json``; a given
        configuration must equal it (`harness._resume`).
    out : path
        Run directory.
    make_executor : callable
        ``make_executor(timeout)`` returns the `Executor` that runs the cells.
    resume, force : bool
        Continue the run in ``out`` / replace the run in ``out`` (only the files it wrote are removed).
    reporter : Reporter, optional
        Progress events.
    command : list of str, optional
        The command line, for ``run.json``.
    execution : dict, optional
        How the cells run (executor, jobs or scheduler), for ``run.json``.
    retry_failed : bool
        With ``resume``: also run again the cells recorded `harness._failures.RETRIED_STATUSES`
        (``--retry-failed``).
    constraint_origins : mapping, optional
        The constraints file of each ``together``/``apart`` pair of ``config`` read from one
        (`harness._cli_constraints.grid_constraints`), named when such a pair names a shape a rig lacks.

    Returns
    -------
    RunSummary
        ``summary.lost`` is non-empty when the infrastructure lost cells (``run.json`` then says
        ``incomplete``; ``--resume`` runs them).

    Raises
    ------
    RunDirectoryError, ValueError
        For an unusable directory or configuration (before any cell runs).
    harness._records.RecordsWriteError
        When a records file cannot be written (e.g. the disk is full); finished cells stay recorded.
    KeyboardInterrupt
        On Ctrl-C, after stopping the workers and marking ``run.json`` interrupted.
    """
    out = Path(out)
    reporter = reporter or SilentReporter()
    if retry_failed and not resume:
        raise RunDirectoryError("--retry-failed runs failed cells of a run again: give it with --resume OUT")
    previous = previous_run(out, resume=resume, force=force)
    changes: list[str] = []
    if previous is not None:
        plugins.register_recorded_files(previous.get("versions") or {})
        stored = validate_config(RunConfig.from_dict(previous["config"]))
        if config is not None:
            changes += options_changed(stored, validate_config(config, constraint_origins))
        config = stored
    elif config is None:
        raise ValueError("run_grid needs a configuration unless it resumes a run")
    else:
        config = validate_config(config, constraint_origins)
    inputs = check_rig_files(config.rigs, config.warps, no_warp=NO_WARP)
    digests = {
        digest_key(rig, seed): rig_digest(rig, seed, inputs.get(rig))
        for rig in config.rigs
        for seed in config.seed
    }
    if previous is not None:
        changes += rigs_changed(previous, digests, inputs)
        changes += versions_changed(previous, current_versions(config))
        refuse_changes(out, changes)
    _check_apart_from_rigs(out, config.rigs)
    if out.exists() and not out.is_dir():
        raise RunDirectoryError(f"--out {out} exists and is not a folder; choose another --out")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise write_error(out, error) from None
    with locked(out):
        return _run_locked(
            config,
            out,
            digests,
            inputs,
            previous,
            make_executor,
            force,
            reporter,
            command,
            execution,
            retry_failed,
        )


def _run_locked(
    config: RunConfig,
    out: Path,
    digests: dict[str, str],
    inputs: dict[str, RigInputs],
    previous: dict[str, Any] | None,
    make_executor: Callable[[float | None], Executor],
    force: bool,
    reporter: Reporter,
    command: list[str] | None,
    execution: dict[str, Any] | None,
    retry_failed: bool,
) -> RunSummary:
    """`run_grid` once the folder is locked."""
    solver_infos = {name: plugins.solver_info(name) for name in config.solvers}
    unavailable = {
        name: item.reason or "unavailable" for name, item in solver_infos.items() if not item.available
    }
    cells = config.cells(digests)
    if previous is not None:
        previous = read_run(out)  # as the last writer left it, now that no other run can write it
        folder = open_for_resume(out)
        done, set_aside_parts = repair_parts(out, folder, {spec.id for spec in cells})
        if retry_failed:
            done -= failed_cells(out)
    else:
        folder = open_new(out, force)
        done, set_aside_parts = set(), {}
    pending = [spec for spec in cells if spec.id not in done]
    runnable = [spec for spec in pending if spec.solver not in unavailable]
    executor = make_executor(config.timeout) if runnable else None  # an unreachable cluster fails here
    summary = RunSummary(
        out, total=len(cells), already_done=len(cells) - len(pending), set_aside=set_aside_parts
    )
    info: dict[str, Any] = {}
    state, failure = "interrupted", None  # (what the run is, once it ends however it ends)
    try:
        if previous is None:
            remove_previous(folder)
        info = previous or _new_run_info(out, config, command)
        if previous is not None:
            info["state"], info["finished"] = "running", None
            info["resumed"] = [*info.get("resumed", []), now()]
            info.pop("error", None)
        info["n_cells"] = len(cells)
        info["rig_digests"] = digests
        info["rig_inputs"] = {rig: found.document() for rig, found in inputs.items()}
        info["execution"] = {**(execution or {}), "pid": os.getpid(), "host": socket.gethostname()}
        info["lost"] = {}
        info["crashes"] = {cell: entry for cell, entry in info.get("crashes", {}).items() if cell not in done}
        write_run(out, info, folder)

        clock = time.perf_counter()
        for path, reason in set_aside_parts.items():
            reporter.notice(f"set aside broken part file {path}: {reason}; its cell runs again")
        reporter.begin(len(cells), summary.already_done, pending, unavailable)
        for spec in pending:
            if spec.solver in unavailable:
                reason = f"solver {spec.solver!r} unavailable: {unavailable[spec.solver]}"
                _record(out, folder, spec, failure_rows(spec, "skipped", reason), summary, reporter)
        if executor is not None:
            check = CellChecker()  # (every answer checked here, not only in the worker that gave it)
            for spec, outcome in executor.map(runnable):
                if isinstance(outcome, Lost) and outcome.crash:
                    outcome = count_crash(info["crashes"], spec, outcome)
                if isinstance(outcome, Lost):
                    _lose(out, folder, info, spec, outcome.reason, summary, reporter)
                else:
                    info["crashes"].pop(spec.id, None)
                    _record(out, folder, spec, check(spec, outcome), summary, reporter)
        _certify(out, folder, {spec.id for spec in pending}, summary, reporter)
        summary.seconds = time.perf_counter() - clock
        state, failure = ("incomplete" if summary.lost else "complete"), None
    except KeyboardInterrupt:
        state, failure = "interrupted", None
        raise
    except BaseException as error:
        state, failure = "failed", str(error)
        raise
    finally:
        try:
            _close_quietly(executor)
            reporter.end()
        finally:  # (a stop that comes while the workers close cannot keep run.json "running")
            with stop_signals_deferred():
                _mark(out, folder, info, state, error=failure, quietly=state in ("interrupted", "failed"))
    return summary


def _new_run_info(out: Path, config: RunConfig, command: list[str] | None) -> dict[str, Any]:
    """The ``run.json`` of a new run (see the module docstring for the keys)."""
    return {
        "format": RUN_FORMAT,
        "state": "running",
        "command": command or sys.argv,
        "config": config.to_dict(),
        "n_cells": 0,
        "rig_digests": {},
        "versions": current_versions(config),
        "git": environment.git_state(output=out),
        "machine": environment.machine(),
        "started": now(),
        "finished": None,
        "resumed": [],
    }


def write_run(out: Path, info: dict[str, Any], folder: OutputFolder) -> None:
    """Write ``run.json`` atomically (listed in the folder's manifest)."""
    data = (json.dumps(info, indent=2, default=str) + "\n").encode()
    write_listed(folder, RUN_FILE, data)


def _record(
    out: Path,
    folder: OutputFolder,
    spec: CellSpec,
    rows: list[Row],
    summary: RunSummary,
    reporter: Reporter,
) -> None:
    write_listed(folder, f"{RECORDS_DIR}/{spec.id}.parquet", part_bytes(spec.id, rows))
    summary.statuses[rows[0]["status"]] += 1
    reporter.cell_finished(spec, rows)


def _certify(
    out: Path, folder: OutputFolder, session: set[str], summary: RunSummary, reporter: Reporter
) -> None:
    """Mark the cells whose claims the run's other cells contradict (`harness._certificate`), over every
    cell recorded so far, whichever process or session computed it."""
    for cell, message in certify(out, folder).items():
        if cell in session:
            summary.statuses["ok"] -= 1
            if summary.statuses["ok"] <= 0:
                del summary.statuses["ok"]
        summary.statuses[INCONSISTENT] += 1
        reporter.notice(f"cell {cell} is {INCONSISTENT}: {message}")


def _lose(
    out: Path,
    folder: OutputFolder,
    info: dict[str, Any],
    spec: CellSpec,
    reason: str,
    summary: RunSummary,
    reporter: Reporter,
) -> None:
    """A cell without result: no part file; ``run.json`` lists it (written at once, a later crash keeps
    the reason) and ``--resume`` runs it again."""
    summary.lost[spec.id] = reason
    info["lost"][spec.id] = {"cell": spec.label(), "reason": reason}
    write_run(out, info, folder)
    reporter.cell_lost(spec, reason)


def _close_quietly(executor: Executor | None) -> None:
    if executor is None:
        return
    try:
        executor.close()
    except Exception:  # noqa: BLE001 - already failing; the original error is what the user needs
        pass


def _mark(
    out: Path,
    folder: OutputFolder,
    info: dict[str, Any],
    state: str,
    *,
    error: str | None = None,
    quietly: bool = False,
) -> None:
    """Record the run's end in ``run.json``.

    Raises
    ------
    harness._records.RecordsWriteError
        When ``run.json`` cannot be written (e.g. the disk is full), unless ``quietly``: a run already
        failing keeps its own error (``run.json`` then still says ``running``, and ``--resume`` works the
        same), while a run that could not record its end must not end as if it had.
    """
    if not info:  # failed before run.json was written
        return
    info["state"], info["finished"] = state, now()
    if error:
        info["error"] = error
    try:
        write_run(out, info, folder)
    except OSError:
        if not quietly:
            raise
