"""The records store of a run: one long table in Parquet part files, written atomically per cell.

Layout of a run directory ``OUT/``:

- ``OUT/run.json``: exact configuration, versions, git commit, machine, start and end (see `harness._run`).
- ``OUT/records/<cell>.parquet``: one part file per finished cell. Temporary files start with ``.`` and never
  end in ``.parquet``, so a crash or a full disk never leaves a half-written part that readers would see.
- ``OUT/overlap.parquet``: the paper's Table 3, computed from the records at the end of every run.

Records table (long format, one schema for every row, null where a column does not apply).

Columns identifying the cell, on every row:

============== ============== ================================================================================
column         dtype          meaning
============== ============== ================================================================================
cell           string         cell id, 16 hex digits of the SHA-256 of the canonical cell spec
kind           string         ``cell`` (one per finished cell), ``expression`` or ``transfer``
rig            string         rig preset name or rig file path, as given
rig_seed       int64          generator seed (0 for rig files)
warp           string         warp preset name; ``none`` means the target is the template itself
solver         string         solver plugin name
mu             float64        binary blendshape threshold (eq. 2)
alpha, beta    float64        importance mix (eq. 4)
symmetry       bool           symmetry pairs forced together (sec. 4.4)
importance     bool           importance weights (eq. 4); False = every weight 1
cap            int64, null    most shapes per expression (sec. 6); null = no cap
jmax           int64, null    most expressions in the sequence; null = until every shape is used
time_limit     float64, null  per-solve time limit in seconds
repetition     int64          0-based repetition index
seed           int64          solver seed of the cell (run seed + repetition)
n_vertices     int64, null    N of the rig (null when the rig could not be built)
n_shapes       int64, null    K of the rig
status         string         per kind, see below
message        string         error, skip, timeout or check message; empty otherwise
============== ============== ================================================================================

``kind == "cell"``, exactly one per finished cell (``--resume`` skips cells that have one). ``status`` is
``ok``, ``skipped`` (solver unavailable, message = the reason), ``error`` (rig, solver or packing raised, or
a solver reported an error; message), ``timeout`` (killed after ``--timeout``) or ``invalid`` (`packing.check`
rejected the sequence; message = the violation). Cells that are not ``ok`` have no expression or transfer
rows:

================ ============== ==============================================================================
analysis_time    float64        seconds of rig analysis (binary shapes, importance, symmetry, presolve)
sequence_time    float64        seconds, sum of presolve, build, solve and extra time over the expressions
cell_time        float64        seconds of the whole cell in its worker (packing, check and transfers)
n_expressions    int64          length of the sequence
n_covered        int64          shapes used as primary examples by the whole sequence
n_pairs          int64          symmetry pairs found
n_empty          int64          empty shapes excluded from packing
lower_bound      int64, null    lower bound on the number of expressions (largest conflict clique)
min_expressions  int64, null    fewest expressions covering every shape (solvers' minimum mode; null when
                                the cell's solver has no such mode)
min_expressions_status string, null  ``optimal`` (proved) or ``feasible`` (time limit) for min_expressions
backend_version  string         solver backend and version
worker           string         ``host:pid`` of the process that ran the cell
finished         string         ISO 8601 time the cell finished
================ ============== ==============================================================================

``kind == "expression"``, one per (cell, expression):

================ ============== ==============================================================================
expression       int64          1-based position in the sequence
shapes           list<string>   primary shapes of the expression (a symmetry pair contributes both)
n_chosen         int64          number of primary shapes
extra_examples   list<string>   already-used shapes added by the sec. 6 second pass
objective        float64        eq. 3a value the solver maximised (weights carry packing's tie-break)
weight           float64        the same without the tie-break: importance (eq. 4) of the chosen shapes
bound            float64, null  best proved bound (null for heuristics)
status           string         ``optimal``, ``feasible`` or ``none`` (what the solution is)
termination      string         ``optimal``, ``completed``, ``time_limit``, ``infeasible``, ``error``
presolve_time    float64        seconds to derive the expression's problem (restrict and presolve)
build_time       float64        seconds to build the backend model
solve_time       float64        seconds in the backend
extra_time       float64        seconds choosing extra examples (sec. 6 second pass; 0 when off)
n_items          int64          items available to this expression
vertex_rows      int64          eq. 3b rows before presolve (vertices active in an available item)
clique_rows      int64          rows after presolve (maximal conflict sets)
covered          int64          shapes covered by expressions 1..expression
coverage         float64        covered / n_shapes
================ ============== ==============================================================================

``kind == "transfer"``, one per (cell, J, transfer method):

================ ============== ==============================================================================
transfer         string         transfer plugin name
j                int64          leading expressions used as training examples: each --j-values entry
                                capped by the sequence length (so the whole sequence is always included)
rms              float64, null  per-vertex RMS error against the target's true blendshapes (rig units)
rms_covered      float64, null  the same over shapes covered by the J expressions (null when none)
rms_uncovered    float64, null  the same over the other shapes (null when none)
worst_shapes     list<string>   the 5 shapes with the largest error, worst first
worst_rms        list<float64>  their per-vertex RMS errors
transfer_time    float64        seconds this row took (transfer and metrics; a look-up when reused)
transfer_reused  bool           the estimate came from an identical earlier transfer in the same worker
                                (same rig, warp, method and weights, e.g. exact solvers that agree; or a
                                method that ignores the training expressions): time the method by rows
                                where this is False
status           string         ``ok`` or ``error`` (message says why)
================ ============== ==============================================================================

The columns in `TIMING_COLUMNS` change from run to run; two runs of one configuration agree on all others,
whichever executor ran them.
"""

from __future__ import annotations

import errno
import os
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

_STRINGS = pa.list_(pa.string())

#: Column name -> Arrow type of the records table, in file order.
RECORD_COLUMNS: dict[str, pa.DataType] = {
    "cell": pa.string(),
    "kind": pa.string(),
    "rig": pa.string(),
    "rig_seed": pa.int64(),
    "warp": pa.string(),
    "solver": pa.string(),
    "mu": pa.float64(),
    "alpha": pa.float64(),
    "beta": pa.float64(),
    "symmetry": pa.bool_(),
    "importance": pa.bool_(),
    "cap": pa.int64(),
    "jmax": pa.int64(),
    "time_limit": pa.float64(),
    "repetition": pa.int64(),
    "seed": pa.int64(),
    "n_vertices": pa.int64(),
    "n_shapes": pa.int64(),
    "status": pa.string(),
    "message": pa.string(),
    # kind == "cell"
    "analysis_time": pa.float64(),
    "sequence_time": pa.float64(),
    "cell_time": pa.float64(),
    "n_expressions": pa.int64(),
    "n_covered": pa.int64(),
    "n_pairs": pa.int64(),
    "n_empty": pa.int64(),
    "lower_bound": pa.int64(),
    "min_expressions": pa.int64(),
    "min_expressions_status": pa.string(),
    "backend_version": pa.string(),
    "worker": pa.string(),
    "finished": pa.string(),
    # kind == "expression"
    "expression": pa.int64(),
    "shapes": _STRINGS,
    "n_chosen": pa.int64(),
    "extra_examples": _STRINGS,
    "objective": pa.float64(),
    "weight": pa.float64(),
    "bound": pa.float64(),
    "termination": pa.string(),
    "presolve_time": pa.float64(),
    "build_time": pa.float64(),
    "solve_time": pa.float64(),
    "extra_time": pa.float64(),
    "n_items": pa.int64(),
    "vertex_rows": pa.int64(),
    "clique_rows": pa.int64(),
    "covered": pa.int64(),
    "coverage": pa.float64(),
    # kind == "transfer"
    "transfer": pa.string(),
    "j": pa.int64(),
    "rms": pa.float64(),
    "rms_covered": pa.float64(),
    "rms_uncovered": pa.float64(),
    "worst_shapes": _STRINGS,
    "worst_rms": pa.list_(pa.float64()),
    "transfer_time": pa.float64(),
    "transfer_reused": pa.bool_(),
}
RECORD_SCHEMA = pa.schema(list(RECORD_COLUMNS.items()))

#: Columns that differ between two runs of one configuration (times, places, in-worker reuse).
TIMING_COLUMNS: tuple[str, ...] = (
    "analysis_time",
    "sequence_time",
    "cell_time",
    "presolve_time",
    "build_time",
    "solve_time",
    "extra_time",
    "transfer_time",
    "transfer_reused",
    "worker",
    "finished",
)

#: Row order of `read_records`.
SORT_COLUMNS: tuple[str, ...] = ("cell", "kind", "expression", "transfer", "j")

RECORDS_DIR = "records"
OVERLAP_FILE = "overlap.parquet"
_TEMP_PREFIX = "."
_TEMP_SUFFIX = ".partial"


class RecordsWriteError(OSError):
    """A part file could not be written; nothing half-written was left behind."""


def records_table(rows: Iterable[Mapping[str, Any]]) -> pa.Table:
    """Arrow table of record rows in the full records schema; absent columns are null.

    Raises
    ------
    ValueError
        When a row names a column that is not in `RECORD_COLUMNS`.
    """
    rows = list(rows)
    unknown = sorted({key for row in rows for key in row} - RECORD_COLUMNS.keys())
    if unknown:
        raise ValueError(f"record rows carry unknown columns {unknown}; known: {list(RECORD_COLUMNS)}")
    columns = {name: [row.get(name) for row in rows] for name in RECORD_COLUMNS}
    return pa.Table.from_pydict(columns, schema=RECORD_SCHEMA)


def write_table_atomically(table: pa.Table, path: Path) -> None:
    """Write a Parquet file so that ``path`` holds either nothing or the complete file.

    The table goes to a temporary file in the same directory (a name starting with ``.``), is flushed
    and fsynced, then renamed over ``path`` with `os.replace` (atomic on POSIX), and the directory is
    fsynced. On any failure the temporary file is removed and `RecordsWriteError` is raised.
    """
    path = Path(path)
    temp = path.with_name(f"{_TEMP_PREFIX}{path.name}.{os.getpid()}{_TEMP_SUFFIX}")
    try:
        with open(temp, "wb") as handle:
            pq.write_table(table, handle)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(temp, path)
    except OSError as error:
        temp.unlink(missing_ok=True)
        reason = "disk full" if error.errno == errno.ENOSPC else (error.strerror or str(error))
        raise RecordsWriteError(error.errno, f"could not write {path}: {reason}") from error
    except BaseException:
        temp.unlink(missing_ok=True)
        raise
    _fsync_directory(path.parent)


def _fsync_directory(directory: Path) -> None:
    descriptor = os.open(directory, os.O_RDONLY)
    try:
        os.fsync(descriptor)
    finally:
        os.close(descriptor)


def part_path(out: Path, cell: str) -> Path:
    """Path of the part file of one cell."""
    return Path(out) / RECORDS_DIR / f"{cell}.parquet"


def write_part(out: Path, cell: str, rows: Iterable[Mapping[str, Any]]) -> Path:
    """Write the rows of one finished cell as its part file, atomically."""
    path = part_path(out, cell)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_table_atomically(records_table(rows), path)
    return path


def finished_cells(out: Path) -> set[str]:
    """Ids of the cells whose part file exists (complete by construction)."""
    directory = Path(out) / RECORDS_DIR
    if not directory.is_dir():
        return set()
    return {path.stem for path in directory.glob("*.parquet") if not path.name.startswith(_TEMP_PREFIX)}


def remove_partial_files(out: Path) -> list[Path]:
    """Delete temporary files a killed writer left in ``OUT/records``; returns what was removed."""
    directory = Path(out) / RECORDS_DIR
    if not directory.is_dir():
        return []
    stale = [path for path in directory.iterdir() if path.name.startswith(_TEMP_PREFIX)]
    for path in stale:
        path.unlink(missing_ok=True)
    return stale


def read_records(out: str | os.PathLike) -> pd.DataFrame:
    """All records of a run as one DataFrame (columns as in `RECORD_COLUMNS`, rows sorted).

    Parameters
    ----------
    out : path
        The run directory (holding ``records/``).

    Returns
    -------
    pandas.DataFrame
        Integer and boolean columns use pandas' nullable dtypes (``Int64``, ``boolean``); strings are
        objects (None where absent); list columns hold Python lists (None where absent).

    Raises
    ------
    FileNotFoundError
        When ``out`` has no records.
    """
    directory = Path(out) / RECORDS_DIR
    parts = sorted(path for path in directory.glob("*.parquet") if not path.name.startswith(_TEMP_PREFIX))
    if not parts:
        raise FileNotFoundError(f"{out}: no records (expected part files in {directory})")
    table = pa.concat_tables([pq.read_table(path, schema=RECORD_SCHEMA) for path in parts])
    frame = table.to_pandas(types_mapper=_nullable_types)
    for name, arrow_type in RECORD_COLUMNS.items():
        if pa.types.is_list(arrow_type):
            frame[name] = frame[name].map(_as_list)
    return frame.sort_values(list(SORT_COLUMNS), kind="stable", na_position="first").reset_index(drop=True)


def _nullable_types(arrow_type: pa.DataType) -> Any:
    return {pa.int64(): pd.Int64Dtype(), pa.bool_(): pd.BooleanDtype()}.get(arrow_type)


def _as_list(value: Any) -> list[Any] | None:
    return None if value is None else list(value.tolist() if hasattr(value, "tolist") else value)
