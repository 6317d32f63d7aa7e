"""The records store of a run: one long table in Parquet part files, written atomically per cell.

Layout of a run directory ``OUT/``:

- ``OUT/run.json``: exact configuration, versions, git commit, machine, start and end (see `harness._run`).
- ``OUT/records/<cell>.parquet``: one part file per finished cell, named by the 16-hex-digit cell id. It is
  written whole to a temporary file (a name starting with ``.``) and renamed, so a crash or a full disk
  never leaves a half-written part that readers would see. Each part carries its cell id and row count in
  its Parquet metadata and page checksums; ``--resume`` reads every part back (`check_parts`) and moves a
  truncated or corrupt one, or one of a cell outside the run's grid (`foreign_part`: copied in from another
  run), to ``OUT/broken-parts/`` to run its cell again; every reader (`read_records`) refuses such a part
  file. Files in ``records/`` not named
  like a part are no records and are never read, moved or removed.
- ``OUT/.harness-manifest.json``: the files the harness wrote here (`registry.claim`); the run writing
  the folder holds a lock on ``OUT`` itself (`harness._run.locked`).

Records table (long format, one schema for every row, null where a column does not apply). The schema
grows: a part file written before a column was added reads with that column null, so adding a column keeps
earlier runs readable and resumable (`schema_mismatch`, `conformed`).

Columns identifying the cell, on every row:

============== ============== ================================================================================
column         dtype          meaning
============== ============== ================================================================================
cell           string         cell id, 16 hex digits of the SHA-256 of the canonical cell spec
kind           string         ``cell`` (one per finished cell), ``expression`` or ``transfer``
rig            string         rig preset name or rig file path, as given
rig_seed       int64          generator seed of rig and actor (a --seeds value; ignored by rig files)
rig_digest     string         ``sha256:`` content digest of the rig (`harness._grid.rig_digest`): file bytes,
                               a folder's files, or a preset's name, seed and parameters
warp           string         warp preset name; ``none`` means the target is the template itself
solver         string         solver label: plugin name with any settings (``cpsat[workers=2]``)
mu             float64        binary blendshape threshold (eq. 2)
alpha, beta    float64        importance mix (eq. 4)
symmetry       bool           symmetry pairs forced together (sec. 4.4)
importance     bool           importance weights (eq. 4); False = every weight 1
cap            int64, null    most shapes per expression (sec. 6); null = no cap
jmax           int64, null    most expressions in the sequence; null = until every shape is used
time_limit     float64, null  per-solve time limit in seconds
repetition     int64          0-based repetition index
seed           int64          solver seed of the cell (run solver seed + repetition)
n_vertices     int64, null    N of the rig (null when the rig could not be built)
n_shapes       int64, null    K of the rig
status         string         per kind, see below
message        string         error, skip, timeout or check message; empty otherwise
============== ============== ================================================================================

``kind == "cell"``, exactly one per finished cell (``--resume`` skips cells that have one). ``status`` is
``ok``, ``skipped`` (solver unavailable, message = the reason), ``error`` (rig, solver or packing raised, or a
solver reported an error; message), ``timeout`` (killed after ``--timeout``: the cell, or its solver's warm-up
before it), ``crashed`` (its worker process died or failed running it twice, in two sessions; message = how it
ended last, e.g. ``killed by SIGSEGV``) or ``invalid`` (`packing.check` rejected the sequence, checked by the
harness with its own symmetry pairs and the solver's declared ``capabilities.max_overlap``: overlapping
shapes, a bound below the objective, an infeasible verdict (every packing problem has a solution), an
expression of a solver that ran to its end with room left for an unused shape; message = the violation) or
``inconsistent`` (the run's cross-solver certificate, `harness._certificate`: its optimality claim disagrees
with other exact solvers' on the same instance, or another solver's packing beats a bound it proved; message =
the instance, the other solver and both values; like ``invalid``, a quality failure, never a result). A cell
lost to the infrastructure (its worker process died once, the Dask scheduler went away, a Dask worker could
not set it up) has no part file at all, so ``--resume`` runs it again. Cells that are not ``ok`` have no
expression or transfer rows, but a ``timeout`` cell keeps the expressions it finished before it was stopped
(``n_expressions`` of them, as its message says; its sequence was cut there, so they are not checked and it
has no transfers):

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
max_overlap      float64, null  share of an item's active vertices the solver may let another item share
                                (``capabilities.max_overlap``; 0 for eq. 3b): a solver with another
                                allowance solves other problems (null in runs recorded before the column)
worker           string         ``host:pid`` of the process that ran the cell
finished         string         ISO 8601 time the cell finished
================ ============== ==============================================================================

``kind == "expression"``, one per (cell, expression). Its columns record the attributes of the
`packing.Expression` (and through it of its `packing.Solution`), but ``n_chosen``, ``covered`` and
``coverage``, which the cell computes from the sequence (`harness._rows.expression_columns`):

================ ============== ==============================================================================
expression       int64          1-based position in the sequence
shapes           list<string>   primary shapes of the expression (a symmetry pair contributes both)
n_chosen         int64          number of primary shapes
extra_examples   list<string>   already-used shapes added by the sec. 6 second pass
objective        float64        eq. 3a: importance (eq. 4) of the chosen shapes, without packing's tie-break
bound            float64, null  best proved bound (null for heuristics)
status           string         ``optimal``, ``feasible`` or ``none`` (what the solution is)
termination      string         ``optimal``, ``completed``, ``time_limit``, ``infeasible``, ``error``
presolve_time    float64        seconds to derive the expression's problem (restrict and presolve)
build_time       float64        seconds to build the backend model
solve_time       float64        seconds in the backend
cpu_time         float64, null  CPU seconds of the solve call: every thread of the process, the child
                                processes it waited for and its calls to worker processes
                                (`solvers.cpu_seconds`); unlike the seconds above, not the moments the
                                machine gave to another job (null in runs recorded before the column)
extra_time       float64        seconds choosing extra examples (sec. 6 second pass; 0 when off)
n_items          int64          items available to this expression
vertex_rows      int64          eq. 3b rows before presolve (vertices active in an available item)
clique_rows      int64          rows after presolve (maximal conflict sets)
covered          int64          shapes covered by expressions 1..expression
coverage         float64        covered / n_shapes
================ ============== ==============================================================================

``kind == "transfer"``, one per (cell, J, transfer method):

================ ============== ==============================================================================
transfer         string         transfer label: method name with any settings (``ebfr[beta=gcv]``)
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

Columns added since (`_GROWN_COLUMNS`; null in part files written before them):

================ ============== ==============================================================================
distortion       string         triangle distortion of eq. 6 in the importance: ``paper`` or ``excess``
scan_seed        int64          seed of the scan-like training expressions (run scan seed + repetition)
solver_settings  string         the solver label's settings (``workers=2`` of ``cpsat[workers=2]``), or ""
transfer_beta    float64, null  (transfer rows) the balance beta the method fitted with (Li et al. sec. 3A):
                                its fixed value, or the one chosen from the data (``ebfr[beta=gcv]``)
examples         string         training expressions of the transfers: ``scan`` or ``ideal`` (the cell's
                                sequence), or ``random`` (random examples instead, `harness._animation`)
mode             string         ``sequence`` (Algorithm 1 with the cell's solver, then transfers) or
                                ``replay`` (``--replay``: the subproblems of one reference sequence, one
                                ``expression`` row each, ``expression`` the instance's index; no transfers;
                                `harness._replay`)
permutation      int64          item order the solver saw (``--permutations``): 0 as built, p > 0 shuffled,
                                seeded by p (`harness._permute`)
frames_l2        float64, null  (transfer rows of runs with ``--frames F``) Wagner et al.'s Fig. 10 error: the
                                mean over F random source frames and the vertices of the L2 distance between
                                the retargeted frame and the target's (rig units); ``rms`` is null there
================ ============== ==============================================================================

The columns in `TIMING_COLUMNS` (every ``*_time`` column, ``transfer_reused``, ``worker`` and ``finished``)
change from run to run; two runs of one configuration agree on all others, whichever executor ran them.
"""

from __future__ import annotations

import errno
import os
import re
import types
import typing
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from harness._rows import ColumnType, RecordValue, expression_columns
from harness._run_file import RUN_FILE, read_run, run_cells
from packing import Expression
from registry import (
    HarnessError,
    OutputFolder,
    OutputFolderError,
    atomic_write,
    claim,
    move_apart,
    reopen,
    staged_target,
)

if TYPE_CHECKING:
    import numpy as np

_STRINGS = pa.list_(pa.string())
_ARROW_TYPES: dict[type, pa.DataType] = {
    bool: pa.bool_(),
    int: pa.int64(),
    float: pa.float64(),
    str: pa.string(),
}

#: Columns of every row, then of ``kind == "cell"`` rows, in file order.
_CELL_COLUMNS: dict[str, pa.DataType] = {
    "cell": pa.string(),
    "kind": pa.string(),
    "rig": pa.string(),
    "rig_seed": pa.int64(),
    "rig_digest": pa.string(),
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
    "max_overlap": pa.float64(),
    "worker": pa.string(),
    "finished": pa.string(),
}

#: The ``kind == "expression"`` columns in file order: `harness._rows.expression_columns`, typed by the
#: annotations of `packing.Expression`, and `_SEQUENCE_COLUMNS`.
_EXPRESSION_ORDER: tuple[str, ...] = (
    "expression",
    "shapes",
    "n_chosen",
    "extra_examples",
    "objective",
    "bound",
    "termination",
    "presolve_time",
    "build_time",
    "solve_time",
    "extra_time",
    "n_items",
    "vertex_rows",
    "clique_rows",
    "covered",
    "coverage",
    "fallback",
    "cpu_time",
)
#: ``kind == "expression"`` columns the cell computes from the sequence (`harness._cell`).
_SEQUENCE_COLUMNS: dict[str, pa.DataType] = {
    "n_chosen": pa.int64(),
    "covered": pa.int64(),
    "coverage": pa.float64(),
}

#: The ``kind == "transfer"`` columns in file order.
_TRANSFER_COLUMNS: dict[str, pa.DataType] = {
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

#: Columns added since the first release, in the order they came (older part files read them as null).
_GROWN_COLUMNS: dict[str, pa.DataType] = {
    "distortion": pa.string(),
    "scan_seed": pa.int64(),
    "solver_settings": pa.string(),
    "transfer_beta": pa.float64(),
    "examples": pa.string(),
    "mode": pa.string(),
    "permutation": pa.int64(),
    "frames_l2": pa.float64(),
}


def arrow_type(kind: ColumnType) -> pa.DataType:
    """The Arrow type of a records column of plain Python type ``kind`` (`harness._rows.column_type`)."""
    if isinstance(kind, types.GenericAlias):
        (item,) = typing.get_args(kind)
        return pa.list_(_ARROW_TYPES[item])
    return _ARROW_TYPES[kind]


def expression_section(
    expression_type: type[Expression] = Expression, shared: Sequence[str] = tuple(_CELL_COLUMNS)
) -> dict[str, pa.DataType]:
    """The ``kind == "expression"`` columns, derived from the attributes of ``expression_type``.

    `_EXPRESSION_ORDER` keeps the order of the files written so far; a recorded attribute it does not name
    (a field added to `packing.Expression`) follows it. Attributes every row records (``status``,
    ``message``) keep their ``shared`` column.

    Raises
    ------
    TypeError
        When an ordered column is neither computed by the cell nor an attribute of the expression.
    """
    recorded = {column: arrow_type(kind) for column, (_, kind) in expression_columns(expression_type).items()}
    known = {**recorded, **_SEQUENCE_COLUMNS}
    missing = [column for column in _EXPRESSION_ORDER if column not in known]
    if missing:
        raise TypeError(f"records columns {missing} are no attribute of {expression_type.__qualname__}")
    added = [column for column in recorded if column not in (*_EXPRESSION_ORDER, *shared)]
    return {column: known[column] for column in (*_EXPRESSION_ORDER, *added)}


#: Column name -> Arrow type of the records table, in file order.
RECORD_COLUMNS: dict[str, pa.DataType] = {
    **_CELL_COLUMNS,
    **expression_section(),
    **_TRANSFER_COLUMNS,
    **_GROWN_COLUMNS,
}
RECORD_SCHEMA = pa.schema(list(RECORD_COLUMNS.items()))

#: Columns every part file has had from the first release of the schema on: which cell, what kind of row.
_REQUIRED_COLUMNS: tuple[str, ...] = ("cell", "kind", "status")

#: Columns that differ between two runs of one configuration: the seconds (``*_time``), the in-worker
#: reuse of a transfer, and where and when a cell ran.
TIMING_COLUMNS: tuple[str, ...] = (
    *(name for name in RECORD_COLUMNS if name.endswith("_time")),
    "transfer_reused",
    "worker",
    "finished",
)

#: Row order of `read_records`.
SORT_COLUMNS: tuple[str, ...] = ("cell", "kind", "expression", "transfer", "j")

RECORDS_DIR = "records"
#: Kind of a run's files in the folder manifest (`registry.claim`).
RUN_KIND = "run"
#: Where `check_parts` moves part files that do not read back whole.
BROKEN_DIR = "broken-parts"
_PART_NAME = re.compile(r"[0-9a-f]{16}\.parquet")
_CELL_KEY, _ROWS_KEY = b"harness.cell", b"harness.rows"


class RecordsWriteError(OSError):
    """A records file could not be written; nothing half-written was left behind."""


class RecordsReadError(HarnessError):
    """A part file does not read back as the records of its cell."""


def records_table(rows: Iterable[Mapping[str, RecordValue]]) -> pa.Table:
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


def parquet_bytes(table: pa.Table) -> bytes:
    """A table as the bytes of a Parquet file with page checksums."""
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink, write_page_checksum=True)
    return sink.getvalue().to_pybytes()


def part_bytes(cell: str, rows: Iterable[Mapping[str, RecordValue]]) -> bytes:
    """The part file of one finished cell: its rows, with the cell id and row count in the metadata."""
    table = records_table(rows)
    table = table.replace_schema_metadata({_CELL_KEY: cell.encode(), _ROWS_KEY: str(table.num_rows).encode()})
    return parquet_bytes(table)


def write_atomically(path: Path, data: bytes) -> Path:
    """`registry.atomic_write`, creating the folder; any failure is one `RecordsWriteError`.

    ``path`` then holds either its old content or all of ``data``, and no temporary file is left.
    """
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        return atomic_write(path, data)
    except OSError as error:
        raise write_error(path, error) from None


def write_error(path: Path, error: OSError) -> RecordsWriteError:
    """One-line `RecordsWriteError` naming ``path`` and the reason (``disk full`` for ENOSPC)."""
    reason = "disk full" if error.errno == errno.ENOSPC else (error.strerror or str(error))
    return RecordsWriteError(error.errno, f"could not write {path}: {reason}")


def part_path(out: Path, cell: str) -> Path:
    """Path of the part file of one cell."""
    return Path(out) / RECORDS_DIR / f"{cell}.parquet"


def write_part(out: Path, cell: str, rows: Iterable[Mapping[str, RecordValue]]) -> Path:
    """Write the rows of one finished cell as its part file, atomically."""
    return write_atomically(part_path(out, cell), part_bytes(cell, rows))


def part_files(out: Path) -> list[Path]:
    """The part files in ``OUT/records`` (names of the form ``<16 hex digits>.parquet``), sorted."""
    directory = Path(out) / RECORDS_DIR
    if not directory.is_dir():
        return []
    return sorted(path for path in directory.iterdir() if _PART_NAME.fullmatch(path.name))


def part_problem(path: Path) -> str:
    """What makes a part file not the complete records of its cell ("" when it is).

    The file must read back whole with its page checksums, in the records schema, and its metadata
    must name the cell of its file name and the number of rows it holds; every row must belong to that
    cell, the ``cell`` row first and only once.
    """
    cell = path.name.removesuffix(".parquet")
    try:
        if path.is_symlink() or not path.is_file():
            return "not a regular file"
        handle = pq.ParquetFile(path, page_checksum_verification=True)
        schema = handle.schema_arrow
        table = handle.read()
    except (OSError, ValueError, pa.ArrowException) as error:
        return f"unreadable ({_first_line(error)})"
    foreign = schema_mismatch(schema)
    if foreign:
        return foreign
    metadata = schema.metadata or {}
    if metadata.get(_CELL_KEY) != cell.encode():
        return "its metadata names another cell or none"
    if metadata.get(_ROWS_KEY) != str(table.num_rows).encode():
        return f"holds {table.num_rows} rows, but was written with {metadata.get(_ROWS_KEY, b'?').decode()}"
    kinds = table.column("kind").to_pylist()
    if set(table.column("cell").to_pylist()) != {cell} or kinds[:1] != ["cell"] or kinds.count("cell") != 1:
        return "its rows are not one cell's (one cell row first, then that cell's rows)"
    return ""


def schema_mismatch(schema: pa.Schema) -> str:
    """Why a part file's columns are not a part of the records table ("" when they are).

    The records schema grows: a part written before a column was added holds a subset of today's columns,
    each of today's type, and reads with the new columns null (`conformed`). A column the table does not
    have, or one of another type, is not records of this table.
    """
    for field in schema:
        if field.name not in RECORD_COLUMNS:
            return f"its column {field.name!r} is not one of the records table"
        if not field.type.equals(RECORD_COLUMNS[field.name]):
            return f"its column {field.name!r} is {field.type}, not {RECORD_COLUMNS[field.name]}"
    missing = [name for name in _REQUIRED_COLUMNS if name not in schema.names]
    return f"it lacks the column(s) {', '.join(missing)}" if missing else ""


def conformed(table: pa.Table) -> pa.Table:
    """``table`` in today's records schema: columns in order, those it lacks added as nulls."""
    columns = [
        table.column(name) if name in table.column_names else pa.nulls(table.num_rows, type=kind)
        for name, kind in RECORD_COLUMNS.items()
    ]
    return pa.Table.from_arrays(columns, schema=RECORD_SCHEMA)


def check_parts(out: Path) -> tuple[set[str], dict[Path, str]]:
    """Read every part file back (`part_problem`).

    Returns
    -------
    set of str
        Ids of the cells whose part file is complete.
    dict of Path to str
        The broken part files and what is wrong with each.
    """
    done, broken = set(), {}
    for path in part_files(out):
        problem = part_problem(path)
        if problem:
            broken[path] = problem
        else:
            done.add(path.name.removesuffix(".parquet"))
    return done, broken


def set_aside(out: Path, path: Path) -> Path:
    """Move a broken part file to ``OUT/broken-parts/`` (never over another file); returns where to."""
    return move_apart(path, Path(out) / BROKEN_DIR)


def remove_partial_files(out: Path, names: Iterable[str] = ()) -> list[Path]:
    """Delete the temporary files a killed writer left: in ``OUT/records`` those of part files, in ``OUT``
    those of the files ``names``. Returns what was removed."""
    out, wanted = Path(out), set(names)
    folders = (
        (out / RECORDS_DIR, lambda name: _PART_NAME.fullmatch(name) is not None),
        (out, lambda name: name in wanted),
    )
    stale = []
    for folder, ours in folders:
        if not folder.is_dir():
            continue
        for path in sorted(folder.iterdir()):
            target = staged_target(path.name)  # (`registry.atomic_write`'s temporary files only)
            if target is not None and ours(target) and path.is_file() and not path.is_symlink():
                path.unlink(missing_ok=True)
                stale.append(path)
    return stale


def save_manifest(folder: OutputFolder) -> None:
    """Save the manifest; a failure (e.g. a full disk) is a `RecordsWriteError` naming the file and why."""
    try:
        folder.save()
    except OutputFolderError as error:
        raise _folder_write_error(error) from None


def _folder_write_error(error: OutputFolderError) -> RecordsWriteError:
    """A manifest write that failed, with the errno of the `OSError` behind it (ENOSPC for a full disk)."""
    code = getattr(error.__context__, "errno", None) or errno.EIO
    return RecordsWriteError(code, str(error).partition("; ")[0])


def write_listed(folder: OutputFolder, name: str, data: bytes) -> Path:
    """Write ``OUT/name`` atomically, listed in the manifest *before* it is in place (`OutputFolder.write`):
    however the process ends, the folder never holds a file the run wrote that the manifest does not list.

    Raises
    ------
    RecordsWriteError
        When the file or the manifest cannot be written (e.g. the disk is full).
    """
    path = folder.path / name
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        return folder.write(name, data)
    except OutputFolderError as error:
        raise _folder_write_error(error) from None
    except OSError as error:
        raise write_error(path, error) from None


def open_new(out: Path, force: bool) -> OutputFolder:
    """Claim ``out`` for a new run (`registry.claim`: new or empty, or with ``force`` holding only an
    earlier run's unchanged files) and save its manifest.

    Raises
    ------
    OutputFolderError
        When the folder holds anything the harness did not write, or an earlier run and not forced.
    """
    folder = claim(out, kind=RUN_KIND, force=force)
    save_manifest(folder)
    return folder


def remove_previous(folder: OutputFolder) -> None:
    """Remove the files of the run this one replaces (`open_new` found only those in the folder)."""
    try:
        folder.clear()
    except OutputFolderError as error:
        raise _folder_write_error(error) from None


def open_for_resume(out: Path) -> OutputFolder:
    """The manifest of a run folder being resumed, without its temporary files a killed writer left."""
    folder = reopen(out, kind=RUN_KIND)
    remove_partial_files(out, names=(RUN_FILE,))
    return folder


def foreign_part(cell: str, grid: set[str] | None) -> str:
    """Why the part file of ``cell`` is not one of the run whose grid has the cells ``grid``
    (`harness._run_file.run_cells`; None for a run that does not describe its grid): "" when it is one.
    ``--resume`` sets such a part aside, and every reader refuses it (`read_records`)."""
    return "" if grid is None or cell in grid else "not a cell of this run's grid"


def repair_parts(out: Path, folder: OutputFolder, grid: set[str]) -> tuple[set[str], dict[Path, str]]:
    """Read every part file back; set aside the broken ones and those of cells not in the grid
    (`foreign_part`); list the good ones (and ``run.json``) in the manifest. Returns the finished cell ids
    and what was set aside."""
    done, broken = check_parts(out)
    for cell in sorted(done):
        problem = foreign_part(cell, grid)
        if problem:
            broken[part_path(out, cell)] = problem
            done.discard(cell)
    moved = {}
    for path, reason in sorted(broken.items()):
        try:
            moved[set_aside(out, path)] = reason
        except OSError as error:
            raise write_error(path, error) from None
        folder.files.pop(path.relative_to(out).as_posix(), None)
    for cell in sorted(done):
        folder.record(f"{RECORDS_DIR}/{cell}.parquet")
    folder.record(RUN_FILE)
    save_manifest(folder)
    return done, moved


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
    RecordsReadError
        When a part file cannot be read, or is not one of the run's cells (`foreign_part`: a part copied
        in from another run), naming it (``harness run --resume`` sets it aside and redoes its cell).
    harness.RunDirectoryError
        When ``run.json`` is not a run file.
    """
    parts = part_files(Path(out))
    if not parts:
        raise FileNotFoundError(f"{out}: no records (expected part files in {Path(out) / RECORDS_DIR})")
    grid = run_cells(read_run(out)) if (Path(out) / RUN_FILE).is_file() else None
    tables = []
    for path in parts:
        try:
            table = pq.read_table(path)
            foreign = schema_mismatch(table.schema) or _not_its_cell(path, table, grid)
            if foreign:
                raise ValueError(foreign)
            tables.append(conformed(table))
        except (OSError, ValueError, pa.ArrowException) as error:
            raise RecordsReadError(
                f"{path}: not a readable part file of this run ({_first_line(error)}); "
                f"harness run --resume {out} sets it aside and runs its cell again"
            ) from None
    frame = pa.concat_tables(tables).to_pandas(types_mapper=_nullable_types)
    for name, arrow_type in RECORD_COLUMNS.items():
        if pa.types.is_list(arrow_type):
            frame[name] = frame[name].map(_as_list)
    return frame.sort_values(list(SORT_COLUMNS), kind="stable", na_position="first").reset_index(drop=True)


def _not_its_cell(path: Path, table: pa.Table, grid: set[str] | None) -> str:
    """Why a part file's rows are not the records of the run's cell its name gives ("" when they are)."""
    cell = path.name.removesuffix(".parquet")
    if set(table.column("cell").to_pylist()) - {cell}:
        return "its rows are another cell's"
    return foreign_part(cell, grid)


def _first_line(error: BaseException) -> str:
    lines = [line for line in str(error).splitlines() if line.strip()]
    return lines[0].strip() if lines else type(error).__name__


def _nullable_types(column: pa.DataType) -> pd.api.extensions.ExtensionDtype | None:
    return {pa.int64(): pd.Int64Dtype(), pa.bool_(): pd.BooleanDtype()}.get(column)


def _as_list(value: np.ndarray | list[str] | list[float] | None) -> list[str] | list[float] | None:
    return None if value is None else list(value.tolist() if hasattr(value, "tolist") else value)
