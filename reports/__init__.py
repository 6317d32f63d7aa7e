"""Reports of runs: timing, overlap and expression-count tables, coverage and RMS figures, expression contact
sheets, a self-contained HTML page with its Markdown twin, and run-to-run comparison for CI.

Everything here reads a run's records (`harness.read_records`); nothing is recomputed.
"""

from harness import claims_table
from reports._compare import Change, Comparison, compare, comparison_table
from reports._contact import contact_sheet
from reports._figures import coverage_figure, rms_figure
from reports._paper import PAPER_OVERLAP, PAPER_TIMINGS
from reports._png import png_bytes
from reports._report import build_report
from reports._tables import (
    BASELINE_SOLVER,
    REFERENCE_TRANSFERS,
    cell_times,
    expression_count_table,
    overlap_table,
    problem_table,
    rms_table,
    separation_table,
    timing_table,
    worst_shapes_table,
)

__all__ = [
    "BASELINE_SOLVER",
    "REFERENCE_TRANSFERS",
    "PAPER_OVERLAP",
    "PAPER_TIMINGS",
    "Change",
    "Comparison",
    "build_report",
    "cell_times",
    "claims_table",
    "compare",
    "comparison_table",
    "contact_sheet",
    "coverage_figure",
    "expression_count_table",
    "overlap_table",
    "png_bytes",
    "problem_table",
    "rms_table",
    "separation_table",
    "rms_figure",
    "timing_table",
    "worst_shapes_table",
]
