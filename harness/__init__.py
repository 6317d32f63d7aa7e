"""The `harness` command and its library: the experiment grid, executors, the records store, resume.

Runs write ``OUT/run.json`` and ``OUT/records/*.parquet``; `read_run` and `read_records` read them back (the
columns are documented in `harness._records`); the tables made from them are the `reports` package's. The
harness runs rigs through `packing`, `solvers` and `transfer` and never computes results itself. Beside
them, the pieces other commands build on (`session`'s ``harness pack``, plugin commands): the shared options
(`packing_options`, `constraint_options`, `DURATION`, ...), the output folder (`claim`), the plugins
(`load_solver`) and a solver in a worker process of its own (`IsolatedSolver`).

Names are imported from their modules on first use (PEP 562), so that ``harness --help`` and the commands
that need no records store start without importing pandas and pyarrow.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import lazy_loader

if TYPE_CHECKING:
    from harness._bench_session import SAMPLE_COLUMNS, Measurement, ProbeError, measure
    from harness._bench_suites import SUITES, Group, Suite, suite
    from harness._cli_constraints import check_file_pairs, constraint_options, constraint_params
    from harness._cli_packing import JMAX, packing_options, packing_params
    from harness._cli_types import COUNT, DURATION, SOLVER_SEED, FiniteFloatRange, terminal
    from harness._commits import (
        CodeVersion,
        CommitError,
        CommitFacts,
        commit_facts,
        commit_range,
        first_parents,
        prepare,
        remove_worktree,
        repository_of,
        resolve,
    )
    from harness._durations import format_duration, parse_duration
    from harness._environment import commits_since, machine
    from harness._executors import DaskExecutor, LocalExecutor
    from harness._grid import (
        DEFAULT_J_VALUES,
        GROUP_COLUMNS,
        PRESETS,
        VARIATION_FIELDS,
        CellSpec,
        RunConfig,
    )
    from harness._isolated import IsolatedSolver, SolverFailure, last_line, late_allowance
    from harness._plugins import check_settings, expand_names, load_solver, solver_names
    from harness._records import RECORD_COLUMNS, TIMING_COLUMNS, RecordsWriteError, read_records
    from harness._rigspec import input_paths, resolve_rig
    from harness._run import RunSummary, in_progress, run_grid
    from harness._run_file import RunDirectoryError, read_run
    from harness._settings import settings_text, split_label, split_requests
    from harness._track_store import StoreError, TrackStore, machine_id

__getattr__, __dir__, __all__ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "_bench_session": ["SAMPLE_COLUMNS", "Measurement", "ProbeError", "measure"],
        "_bench_suites": ["SUITES", "Group", "Suite", "suite"],
        "_commits": [
            "CodeVersion",
            "CommitError",
            "CommitFacts",
            "commit_facts",
            "commit_range",
            "first_parents",
            "prepare",
            "remove_worktree",
            "repository_of",
            "resolve",
        ],
        "_cli_constraints": ["check_file_pairs", "constraint_options", "constraint_params"],
        "_cli_packing": ["JMAX", "packing_options", "packing_params"],
        "_cli_types": ["COUNT", "DURATION", "SOLVER_SEED", "FiniteFloatRange", "terminal"],
        "_durations": ["format_duration", "parse_duration"],
        "_environment": ["commits_since", "machine"],
        "_executors": ["DaskExecutor", "LocalExecutor"],
        "_grid": [
            "DEFAULT_J_VALUES",
            "GROUP_COLUMNS",
            "PRESETS",
            "VARIATION_FIELDS",
            "CellSpec",
            "RunConfig",
        ],
        "_isolated": ["IsolatedSolver", "SolverFailure", "last_line", "late_allowance"],
        "_records": ["RECORD_COLUMNS", "TIMING_COLUMNS", "RecordsWriteError", "read_records"],
        "_plugins": ["check_settings", "expand_names", "load_solver", "solver_names"],
        "_rigspec": ["input_paths", "resolve_rig"],
        "_run": ["RunSummary", "in_progress", "run_grid"],
        "_run_file": ["RunDirectoryError", "read_run"],
        "_settings": ["settings_text", "split_label", "split_requests"],
        "_track_store": ["StoreError", "TrackStore", "machine_id"],
    },
)
