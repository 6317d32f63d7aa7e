"""The public names of `harness`, read by type checkers and by its lazy loader (`lazy_loader.attach_stub`):
each is imported from its module on first use."""

from ._bench_session import (
    SAMPLE_COLUMNS as SAMPLE_COLUMNS,
    Measurement as Measurement,
    ProbeError as ProbeError,
    measure as measure,
)
from ._bench_suites import (
    SUITES as SUITES,
    Group as Group,
    Suite as Suite,
    suite as suite,
)
from ._cli_constraints import (
    check_file_pairs as check_file_pairs,
    constraint_options as constraint_options,
    constraint_params as constraint_params,
)
from ._cli_packing import (
    JMAX as JMAX,
    packing_options as packing_options,
    packing_params as packing_params,
)
from ._cli_types import (
    COUNT as COUNT,
    DURATION as DURATION,
    SOLVER_SEED as SOLVER_SEED,
    FiniteFloatRange as FiniteFloatRange,
    terminal as terminal,
)
from ._commits import (
    CodeVersion as CodeVersion,
    CommitError as CommitError,
    CommitFacts as CommitFacts,
    commit_facts as commit_facts,
    commit_range as commit_range,
    first_parents as first_parents,
    prepare as prepare,
    remove_worktree as remove_worktree,
    repository_of as repository_of,
    resolve as resolve,
)
from ._durations import (
    format_duration as format_duration,
    parse_duration as parse_duration,
)
from ._environment import (
    commits_since as commits_since,
    machine as machine,
)
from ._executors import (
    DaskExecutor as DaskExecutor,
    LocalExecutor as LocalExecutor,
)
from ._grid import (
    DEFAULT_J_VALUES as DEFAULT_J_VALUES,
    GROUP_COLUMNS as GROUP_COLUMNS,
    PRESETS as PRESETS,
    VARIATION_FIELDS as VARIATION_FIELDS,
    CellSpec as CellSpec,
    RunConfig as RunConfig,
)
from ._isolated import (
    IsolatedSolver as IsolatedSolver,
    SolverFailure as SolverFailure,
    last_line as last_line,
    late_allowance as late_allowance,
)
from ._plugins import (
    check_settings as check_settings,
    expand_names as expand_names,
    load_solver as load_solver,
    solver_names as solver_names,
)
from ._records import (
    RECORD_COLUMNS as RECORD_COLUMNS,
    TIMING_COLUMNS as TIMING_COLUMNS,
    RecordsWriteError as RecordsWriteError,
    read_records as read_records,
)
from ._run import (
    RunSummary as RunSummary,
    in_progress as in_progress,
    run_grid as run_grid,
)
from ._run_file import (
    RunDirectoryError as RunDirectoryError,
    read_run as read_run,
)
from ._settings import (
    settings_text as settings_text,
    split_label as split_label,
    split_requests as split_requests,
)
from ._track_store import (
    StoreError as StoreError,
    TrackStore as TrackStore,
    machine_id as machine_id,
)
