"""Reports of runs: timing, overlap and expression-count tables, coverage and RMS figures, expression contact
sheets, a self-contained HTML page with its Markdown twin, run-to-run comparison for CI, and the history of CI
runs' timings as ratios to a reference solver (`read_history`, `append_history`, `run_figures`).

Everything here reads a run's records (`harness.read_records`); nothing is recomputed.

Names are imported from their modules on first use (PEP 562), so that ``harness --help``, which lists the
``report`` and ``compare`` commands, starts without importing pandas or matplotlib.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from harness._claims import claims_table
    from reports._compare import Change, Comparison, compare, comparison_table, run_figures
    from reports._contact import contact_sheet
    from reports._figures import coverage_figure, history_figure, rms_figure
    from reports._history import HISTORY_COLUMNS, HistoryError, Spread, append_history, read_history
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

#: The module that defines each public name.
_MODULE_OF = {
    "claims_table": "harness._claims",
    "Change": "reports._compare",
    "Comparison": "reports._compare",
    "compare": "reports._compare",
    "comparison_table": "reports._compare",
    "run_figures": "reports._compare",
    "contact_sheet": "reports._contact",
    "coverage_figure": "reports._figures",
    "rms_figure": "reports._figures",
    "history_figure": "reports._figures",
    "HISTORY_COLUMNS": "reports._history",
    "HistoryError": "reports._history",
    "Spread": "reports._history",
    "append_history": "reports._history",
    "read_history": "reports._history",
    "PAPER_OVERLAP": "reports._paper",
    "PAPER_TIMINGS": "reports._paper",
    "png_bytes": "reports._png",
    "build_report": "reports._report",
    "BASELINE_SOLVER": "reports._tables",
    "REFERENCE_TRANSFERS": "reports._tables",
    "cell_times": "reports._tables",
    "expression_count_table": "reports._tables",
    "overlap_table": "reports._tables",
    "problem_table": "reports._tables",
    "rms_table": "reports._tables",
    "separation_table": "reports._tables",
    "timing_table": "reports._tables",
    "worst_shapes_table": "reports._tables",
}

__all__ = [
    "BASELINE_SOLVER",
    "HISTORY_COLUMNS",
    "PAPER_OVERLAP",
    "PAPER_TIMINGS",
    "REFERENCE_TRANSFERS",
    "Change",
    "Comparison",
    "HistoryError",
    "Spread",
    "append_history",
    "build_report",
    "cell_times",
    "claims_table",
    "compare",
    "comparison_table",
    "contact_sheet",
    "coverage_figure",
    "expression_count_table",
    "history_figure",
    "overlap_table",
    "png_bytes",
    "problem_table",
    "read_history",
    "rms_figure",
    "rms_table",
    "run_figures",
    "separation_table",
    "timing_table",
    "worst_shapes_table",
]


def __getattr__(name: str) -> Any:
    """Import a public name from its module on first use and keep it in the package namespace."""
    module = _MODULE_OF.get(name)
    if module is None:
        raise AttributeError(f"module 'reports' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
