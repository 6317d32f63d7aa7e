"""The `harness` command and its library: the experiment grid, executors, the records store, resume.

Runs write ``OUT/run.json`` and ``OUT/records/*.parquet``; `read_run`, `read_records` and `read_overlap` read
them back (the columns are documented in `harness._records` and `harness._overlap`). The harness runs rigs
through `packing`, `solvers` and `transfer` and never computes results itself.

Names are imported from their modules on first use (PEP 562), so that ``harness --help`` and the commands
that need no records store start without importing pandas and pyarrow.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import lazy_loader

if TYPE_CHECKING:
    from harness._claims import claims_table
    from harness._durations import format_duration, parse_duration
    from harness._environment import commits_since
    from harness._executors import DaskExecutor, LocalExecutor
    from harness._grid import DEFAULT_J_VALUES, PRESETS, CellSpec, RunConfig
    from harness._overlap import GROUP_COLUMNS, OVERLAP_COLUMNS, overlap_table
    from harness._records import RECORD_COLUMNS, TIMING_COLUMNS, RecordsWriteError, read_records
    from harness._rigspec import resolve_rig
    from harness._run import RunDirectoryError, RunSummary, read_overlap, read_run, run_grid
    from harness._session_render import active_vertices, render_mesh, shape_colours, triangle_colours

__getattr__, __dir__, __all__ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "_claims": ["claims_table"],
        "_durations": ["format_duration", "parse_duration"],
        "_environment": ["commits_since"],
        "_executors": ["DaskExecutor", "LocalExecutor"],
        "_grid": ["DEFAULT_J_VALUES", "PRESETS", "CellSpec", "RunConfig"],
        "_overlap": ["GROUP_COLUMNS", "OVERLAP_COLUMNS", "overlap_table"],
        "_records": ["RECORD_COLUMNS", "TIMING_COLUMNS", "RecordsWriteError", "read_records"],
        "_rigspec": ["resolve_rig"],
        "_run": ["RunDirectoryError", "RunSummary", "read_overlap", "read_run", "run_grid"],
        "_session_render": ["active_vertices", "render_mesh", "shape_colours", "triangle_colours"],
    },
)
