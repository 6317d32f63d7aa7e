"""The `harness` command and its library: the experiment grid, executors, the records store, resume.

Runs write ``OUT/run.json`` and ``OUT/records/*.parquet``; `read_run`, `read_records` and `read_overlap` read
them back (the columns are documented in `harness._records` and `harness._overlap`). The harness runs rigs
through `packing`, `solvers` and `transfer` and never computes results itself.

Names are imported from their modules on first use (PEP 562), so that ``harness --help`` and the commands
that need no records store start without importing pandas and pyarrow.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from harness._claims import claims_table
    from harness._durations import format_duration, parse_duration
    from harness._executors import DaskExecutor, LocalExecutor
    from harness._grid import DEFAULT_J_VALUES, PRESETS, CellSpec, RunConfig
    from harness._overlap import GROUP_COLUMNS, OVERLAP_COLUMNS, overlap_table
    from harness._records import RECORD_COLUMNS, TIMING_COLUMNS, RecordsWriteError, read_records
    from harness._rigspec import resolve_rig
    from harness._run import RunDirectoryError, RunSummary, read_overlap, read_run, run_grid
    from harness._session_render import active_vertices, render_mesh, shape_colours, triangle_colours

#: The module that defines each public name.
_MODULE_OF = {
    "claims_table": "harness._claims",
    "format_duration": "harness._durations",
    "parse_duration": "harness._durations",
    "DaskExecutor": "harness._executors",
    "LocalExecutor": "harness._executors",
    "DEFAULT_J_VALUES": "harness._grid",
    "PRESETS": "harness._grid",
    "CellSpec": "harness._grid",
    "RunConfig": "harness._grid",
    "GROUP_COLUMNS": "harness._overlap",
    "OVERLAP_COLUMNS": "harness._overlap",
    "overlap_table": "harness._overlap",
    "RECORD_COLUMNS": "harness._records",
    "TIMING_COLUMNS": "harness._records",
    "RecordsWriteError": "harness._records",
    "read_records": "harness._records",
    "resolve_rig": "harness._rigspec",
    "RunDirectoryError": "harness._run",
    "RunSummary": "harness._run",
    "read_overlap": "harness._run",
    "read_run": "harness._run",
    "run_grid": "harness._run",
    "active_vertices": "harness._session_render",
    "render_mesh": "harness._session_render",
    "shape_colours": "harness._session_render",
    "triangle_colours": "harness._session_render",
}

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
    "active_vertices",
    "claims_table",
    "format_duration",
    "overlap_table",
    "parse_duration",
    "read_overlap",
    "read_records",
    "read_run",
    "render_mesh",
    "resolve_rig",
    "run_grid",
    "shape_colours",
    "triangle_colours",
]


def __getattr__(name: str) -> Any:
    """Import a public name from its module on first use and keep it in the package namespace."""
    module = _MODULE_OF.get(name)
    if module is None:
        raise AttributeError(f"module 'harness' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
