"""A run: the grid of a `RunConfig` executed cell by cell into ``OUT/``, resumable after any interruption.

``OUT/run.json`` holds (keys in order):

- ``format`` (1), ``state`` (``running``, ``complete``, ``interrupted`` or ``failed``), ``command`` (argv),
- ``config``: the exact `RunConfig` (``--solvers all`` already expanded to names),
- ``n_cells``: size of the grid,
- ``versions``: Python and distributions (`harness._environment.DISTRIBUTIONS`), plus ``solvers`` and
  ``transfers``: per plugin ``available``, ``reason``, ``version``,
- ``git`` (``commit``, ``dirty``), ``machine`` (``hostname``, ``platform``, ``processor``, ``cpu_count``),
- ``execution``: how the cells ran last (``executor`` and ``jobs`` or ``scheduler``),
- ``started``, ``finished`` (ISO 8601, UTC; ``finished`` is null until the run ends), ``resumed`` (list of
  the times ``--resume`` continued it), ``error`` (the message of a ``failed`` run).

Cells run on an executor (`harness._executors`); each finished cell's rows are written at once as its own
part file (`harness._records.write_part`), so an interruption loses only the cells in flight and
``--resume`` runs exactly the cells without a part file.
"""

from __future__ import annotations

import datetime
import itertools
import json
import os
import shutil
import sys
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import pyarrow as pa

from harness import _environment as environment
from harness import _plugins as plugins
from harness._cell import failure_rows
from harness._executors import Executor
from harness._grid import NO_WARP, CellSpec, RunConfig
from harness._overlap import OVERLAP_COLUMNS, overlap_table
from harness._records import (
    OVERLAP_FILE,
    RECORD_COLUMNS,
    RECORDS_DIR,
    finished_cells,
    read_records,
    remove_partial_files,
    write_part,
    write_table_atomically,
)
from harness._rigspec import check_rig_files

RUN_FILE = "run.json"
RUN_FORMAT = 1


class RunDirectoryError(ValueError):
    """The output directory cannot take this run (holds another run, or has nothing to resume)."""


class Reporter(Protocol):
    """Receives progress events (the CLI shows them; tests and library callers may ignore them)."""

    def begin(self, total: int, done: int, pending: list[CellSpec], skipped: dict[str, str]) -> None: ...

    def cell_finished(self, spec: CellSpec, rows: list[dict[str, Any]]) -> None: ...

    def end(self) -> None: ...


class SilentReporter:
    """A `Reporter` that reports nothing."""

    def begin(self, total: int, done: int, pending: list[CellSpec], skipped: dict[str, str]) -> None:
        pass

    def cell_finished(self, spec: CellSpec, rows: list[dict[str, Any]]) -> None:
        pass

    def end(self) -> None:
        pass


@dataclass
class RunSummary:
    """What a finished (or resumed) run did."""

    out: Path
    total: int
    already_done: int
    statuses: Counter[str] = field(default_factory=Counter)
    seconds: float = 0.0


def now() -> str:
    """Current UTC time, ISO 8601, to the second."""
    return datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")


def read_run(out: str | Path) -> dict[str, Any]:
    """The ``run.json`` of a run directory.

    Raises
    ------
    FileNotFoundError
        When ``out`` holds no run.
    """
    path = Path(out) / RUN_FILE
    if not path.is_file():
        raise FileNotFoundError(f"{out}: no {RUN_FILE} here, so no harness run to read")
    return json.loads(path.read_text())


def write_run(out: Path, info: dict[str, Any]) -> None:
    """Write ``run.json`` atomically (temporary file, fsync, rename)."""
    path = Path(out) / RUN_FILE
    temp = path.with_name(f".{RUN_FILE}.partial")
    with open(temp, "w") as handle:
        json.dump(info, handle, indent=2, default=str)
        handle.write("\n")
        handle.flush()
        os.fsync(handle.fileno())
    temp.replace(path)


def validate_config(config: RunConfig) -> RunConfig:
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
    check_rig_files(config.rigs, config.warps, no_warp=NO_WARP)
    if config.repetitions < 1:
        raise ValueError(f"--repetitions must be at least 1, got {config.repetitions}")
    if config.jmax is not None and config.jmax < 1:
        raise ValueError(f"--jmax must be at least 1, got {config.jmax}")
    if any(j < 1 for j in config.j_values):
        raise ValueError(f"--j-values must be positive integers, got {list(config.j_values)}")
    _check_packing_params(config)
    for option, value in (("--time-limit", config.time_limit), ("--timeout", config.timeout)):
        if value is not None and value <= 0:
            raise ValueError(f"{option} must be positive, got {value}")
    return config.with_overrides(solvers=solvers, transfers=transfers)


def _check_packing_params(config: RunConfig) -> None:
    """Let `packing.PackingParams` judge every value of the packing axes (it names the bad one)."""
    import packing

    for values in itertools.product(config.mu, config.alpha, config.beta, config.cap):
        mu, alpha, beta, cap = values
        packing.PackingParams(mu=mu, alpha=alpha, beta=beta, max_per_expression=cap)


def previous_run(out: Path, *, resume: bool, force: bool) -> dict[str, Any] | None:
    """The ``run.json`` to continue when resuming, else None; nothing on disk changes here.

    Raises
    ------
    RunDirectoryError
        When ``out`` holds another run and neither ``resume`` nor ``force`` is given, or when there is
        nothing to resume.
    """
    out = Path(out)
    if resume:
        if not (out / RUN_FILE).is_file():
            raise RunDirectoryError(
                f"{out} holds no run to resume (no {RUN_FILE}); start one without --resume"
            )
        return read_run(out)
    if ((out / RUN_FILE).exists() or (out / RECORDS_DIR).exists()) and not force:
        raise RunDirectoryError(
            f"{out} already holds a run; use --resume to finish it, --force to overwrite it, "
            "or choose another --out"
        )
    return None


def prepare_directory(out: Path, *, resume: bool) -> None:
    """Make ``out`` ready for cells: drop temporary files a killed writer left when resuming, else remove
    the files of any previous run (only the harness's own: ``run.json``, ``records/``, overlap table)."""
    if resume:
        remove_partial_files(out)
        return
    shutil.rmtree(out / RECORDS_DIR, ignore_errors=True)
    for name in (RUN_FILE, OVERLAP_FILE):
        (out / name).unlink(missing_ok=True)
    out.mkdir(parents=True, exist_ok=True)


def run_grid(
    config: RunConfig,
    out: str | Path,
    *,
    make_executor: Callable[[float | None], Executor],
    resume: bool = False,
    force: bool = False,
    reporter: Reporter | None = None,
    command: list[str] | None = None,
    execution: dict[str, Any] | None = None,
) -> RunSummary:
    """Run (or resume) a grid into ``out``.

    Parameters
    ----------
    config : RunConfig
        The grid. Ignored when ``resume`` is true: the configuration stored in ``run.json`` is used.
    out : path
        Run directory.
    make_executor : callable
        ``make_executor(timeout)`` returns the `Executor` that runs the cells.
    resume, force : bool
        Continue the run in ``out`` / overwrite a run in ``out``.
    reporter : Reporter, optional
        Progress events.
    command : list of str, optional
        The command line, for ``run.json``.
    execution : dict, optional
        How the cells run (executor, jobs or scheduler), for ``run.json``.

    Returns
    -------
    RunSummary

    Raises
    ------
    RunDirectoryError, ValueError
        For an unusable directory or configuration (before any cell runs).
    harness._records.RecordsWriteError
        When a part file cannot be written (e.g. the disk is full); finished cells stay recorded.
    KeyboardInterrupt
        On Ctrl-C, after stopping the workers and marking ``run.json`` interrupted.
    """
    out = Path(out)
    reporter = reporter or SilentReporter()
    previous = previous_run(out, resume=resume, force=force)
    if previous is not None:
        config = RunConfig.from_dict(previous["config"])
    config = validate_config(config)
    solver_infos = {name: plugins.solver_info(name) for name in config.solvers}
    unavailable = {
        name: item.reason or "unavailable" for name, item in solver_infos.items() if not item.available
    }
    cells = config.cells()
    done = finished_cells(out) if resume else set()
    pending = [spec for spec in cells if spec.id not in done]
    runnable = [spec for spec in pending if spec.solver not in unavailable]
    executor = make_executor(config.timeout) if runnable else None  # an unreachable cluster fails here
    summary = RunSummary(out, total=len(cells), already_done=len(cells) - len(pending))
    info: dict[str, Any] = {}
    try:
        prepare_directory(out, resume=resume)
        info = previous or _new_run_info(config, solver_infos, command)
        if previous is not None:
            info["state"], info["finished"] = "running", None
            info["resumed"] = [*info.get("resumed", []), now()]
        info["n_cells"] = len(cells)
        info["execution"] = execution or {}
        write_run(out, info)

        clock = time.perf_counter()
        reporter.begin(len(cells), summary.already_done, pending, unavailable)
        for spec in pending:
            if spec.solver in unavailable:
                reason = f"solver {spec.solver!r} unavailable: {unavailable[spec.solver]}"
                _record(out, spec, failure_rows(spec, "skipped", reason), summary, reporter)
        if executor is not None:
            for spec, rows in executor.map(runnable):
                _record(out, spec, rows, summary, reporter)
        write_overlap(out)
        summary.seconds = time.perf_counter() - clock
    except KeyboardInterrupt:
        _mark(out, info, "interrupted")
        raise
    except BaseException as error:
        _mark(out, info, "failed", error=str(error))
        raise
    finally:
        _close_quietly(executor)
        reporter.end()
    _mark(out, info, "complete")
    return summary


def _new_run_info(
    config: RunConfig, solver_infos: dict[str, Any], command: list[str] | None
) -> dict[str, Any]:
    """The ``run.json`` of a new run (see the module docstring for the keys)."""
    return {
        "format": RUN_FORMAT,
        "state": "running",
        "command": command or sys.argv,
        "config": config.to_dict(),
        "n_cells": 0,
        "versions": {
            **environment.versions(),
            "solvers": {name: item.as_dict() for name, item in solver_infos.items()},
            "transfers": {name: plugins.transfer_info(name).as_dict() for name in config.transfers},
        },
        "git": environment.git_state(),
        "machine": environment.machine(),
        "started": now(),
        "finished": None,
        "resumed": [],
    }


def _record(
    out: Path, spec: CellSpec, rows: list[dict[str, Any]], summary: RunSummary, reporter: Reporter
) -> None:
    write_part(out, spec.id, rows)
    summary.statuses[rows[0]["status"]] += 1
    reporter.cell_finished(spec, rows)


def _close_quietly(executor: Executor | None) -> None:
    if executor is None:
        return
    try:
        executor.close()
    except Exception:  # noqa: BLE001 - already failing; the original error is what the user needs
        pass


def _mark(out: Path, info: dict[str, Any], state: str, *, error: str | None = None) -> None:
    if not info:  # failed before run.json was written
        return
    info["state"], info["finished"] = state, now()
    if error:
        info["error"] = error
    try:
        write_run(out, info)
    except OSError:
        pass  # e.g. the disk is full; run.json still says "running" and --resume works the same


def write_overlap(out: Path) -> None:
    """(Re)compute the Table 3 overlap from the records and write ``OUT/overlap.parquet`` atomically."""
    try:
        records = read_records(out)
    except FileNotFoundError:
        return
    table = overlap_table(records)
    schema = pa.schema(
        [
            (name, RECORD_COLUMNS.get(name, pa.string() if name.startswith("solver") else pa.int64()))
            for name in OVERLAP_COLUMNS
        ]
    )
    write_table_atomically(
        pa.Table.from_pandas(table, schema=schema, preserve_index=False), out / OVERLAP_FILE
    )


def read_overlap(out: str | Path) -> Any:
    """The overlap table (`harness._overlap`) of a run as a DataFrame."""
    import pandas as pd
    import pyarrow.parquet as pq

    path = Path(out) / OVERLAP_FILE
    if not path.is_file():
        raise FileNotFoundError(
            f"{out}: no {OVERLAP_FILE} (the run has not finished; run harness run --resume)"
        )
    return pq.read_table(path).to_pandas(
        types_mapper={pa.int64(): pd.Int64Dtype(), pa.bool_(): pd.BooleanDtype()}.get
    )
