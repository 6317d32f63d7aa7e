"""The `harness` command and its library: the experiment grid, executors, the records store, resume.

Runs write ``OUT/run.json`` and ``OUT/records/*.parquet``; `read_run`, `read_records` and `read_overlap` read
them back (the columns are documented in `harness._records` and `harness._overlap`). The harness runs rigs
through `packing`, `solvers` and `transfer` and never computes results itself.
"""

from harness._durations import format_duration, parse_duration
from harness._executors import DaskExecutor, LocalExecutor
from harness._grid import DEFAULT_J_VALUES, PRESETS, CellSpec, RunConfig
from harness._overlap import GROUP_COLUMNS, OVERLAP_COLUMNS, overlap_table
from harness._records import RECORD_COLUMNS, TIMING_COLUMNS, RecordsWriteError, read_records
from harness._rigspec import resolve_rig
from harness._run import RunDirectoryError, RunSummary, read_overlap, read_run, run_grid

__all__ = [
    "DEFAULT_J_VALUES",
    "GROUP_COLUMNS",
    "OVERLAP_COLUMNS",
    "PRESETS",
    "RECORD_COLUMNS",
    "TIMING_COLUMNS",
    "CellSpec",
    "DaskExecutor",
    "LocalExecutor",
    "RecordsWriteError",
    "RunConfig",
    "RunDirectoryError",
    "RunSummary",
    "format_duration",
    "overlap_table",
    "parse_duration",
    "read_overlap",
    "read_records",
    "read_run",
    "resolve_rig",
    "run_grid",
]
