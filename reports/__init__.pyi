"""The public names of `reports`, read by type checkers and by its lazy loader (`lazy_loader.attach_stub`):
each is imported from its module on first use."""

from ._ab import (
    ABComparison as ABComparison,
    CaseVerdict as CaseVerdict,
    compare_measurement as compare_measurement,
)
from ._agreement import (
    AGREEMENT_COLUMNS as AGREEMENT_COLUMNS,
    agreement_counts as agreement_counts,
)
from ._claims import (
    claims_table as claims_table,
)
from ._compare import (
    Change as Change,
    Comparison as Comparison,
    compare as compare,
    comparison_table as comparison_table,
)
from ._contact import (
    contact_sheet as contact_sheet,
)
from ._figures import (
    coverage_figure as coverage_figure,
    distribution_figure as distribution_figure,
    profile_figure as profile_figure,
    rms_figure as rms_figure,
)
from ._gate import (
    Accepted as Accepted,
    read_accepted as read_accepted,
)
from ._paired import (
    PairedTest as PairedTest,
    judge as judge,
    paired_test as paired_test,
)
from ._paper import (
    PAPER_AGREEMENT as PAPER_AGREEMENT,
    PAPER_TIMINGS as PAPER_TIMINGS,
)
from ._png import (
    png_bytes as png_bytes,
)
from ._report import (
    build_report as build_report,
)
from ._steps import (
    Step as Step,
    commit_series as commit_series,
    detect_steps as detect_steps,
)
from ._summary import (
    SHIFT as SHIFT,
    common_table as common_table,
    common_times as common_times,
    outcome_table as outcome_table,
    performance_profile as performance_profile,
    performance_ratios as performance_ratios,
    sequence_table as sequence_table,
    shifted_geometric_mean as shifted_geometric_mean,
    solve_outcomes as solve_outcomes,
    wins as wins,
)
from ._tables import (
    BASELINE_SOLVER as BASELINE_SOLVER,
    REFERENCE_TRANSFERS as REFERENCE_TRANSFERS,
    agreement_table as agreement_table,
    cell_times as cell_times,
    expression_count_table as expression_count_table,
    problem_table as problem_table,
    rms_table as rms_table,
    separation_table as separation_table,
    timing_table as timing_table,
    worst_shapes_table as worst_shapes_table,
)
