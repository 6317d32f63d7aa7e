"""The public names of `reports`, read by type checkers and by its lazy loader (`lazy_loader.attach_stub`):
each is imported from its module on first use."""

from ._ab import (
    ABComparison as ABComparison,
)
from ._ab import (
    CaseVerdict as CaseVerdict,
)
from ._ab import (
    compare_measurement as compare_measurement,
)
from ._agreement import (
    AGREEMENT_COLUMNS as AGREEMENT_COLUMNS,
)
from ._agreement import (
    agreement_counts as agreement_counts,
)
from ._claims import (
    claims_table as claims_table,
)
from ._compare import (
    Change as Change,
)
from ._compare import (
    Comparison as Comparison,
)
from ._compare import (
    compare as compare,
)
from ._compare import (
    comparison_table as comparison_table,
)
from ._contact import (
    contact_sheet as contact_sheet,
)
from ._figures import (
    coverage_figure as coverage_figure,
)
from ._figures import (
    distribution_figure as distribution_figure,
)
from ._figures import (
    profile_figure as profile_figure,
)
from ._figures import (
    rms_figure as rms_figure,
)
from ._gate import (
    Accepted as Accepted,
)
from ._gate import (
    read_accepted as read_accepted,
)
from ._paired import (
    PairedTest as PairedTest,
)
from ._paired import (
    judge as judge,
)
from ._paired import (
    paired_test as paired_test,
)
from ._paper import (
    PAPER_AGREEMENT as PAPER_AGREEMENT,
)
from ._paper import (
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
)
from ._steps import (
    commit_series as commit_series,
)
from ._steps import (
    detect_steps as detect_steps,
)
from ._summary import (
    SHIFT as SHIFT,
)
from ._summary import (
    common_table as common_table,
)
from ._summary import (
    common_times as common_times,
)
from ._summary import (
    outcome_table as outcome_table,
)
from ._summary import (
    performance_profile as performance_profile,
)
from ._summary import (
    performance_ratios as performance_ratios,
)
from ._summary import (
    sequence_table as sequence_table,
)
from ._summary import (
    shifted_geometric_mean as shifted_geometric_mean,
)
from ._summary import (
    solve_outcomes as solve_outcomes,
)
from ._summary import (
    wins as wins,
)
from ._tables import (
    BASELINE_SOLVER as BASELINE_SOLVER,
)
from ._tables import (
    REFERENCE_TRANSFERS as REFERENCE_TRANSFERS,
)
from ._tables import (
    agreement_table as agreement_table,
)
from ._tables import (
    cell_times as cell_times,
)
from ._tables import (
    expression_count_table as expression_count_table,
)
from ._tables import (
    problem_table as problem_table,
)
from ._tables import (
    rms_table as rms_table,
)
from ._tables import (
    separation_table as separation_table,
)
from ._tables import (
    timing_table as timing_table,
)
from ._tables import (
    worst_shapes_table as worst_shapes_table,
)
