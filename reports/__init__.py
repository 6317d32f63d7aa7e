"""Reports of runs: timing, agreement (the paper's Table 3) and expression-count tables, the paper's claims
held or not (``harness show``), coverage and RMS figures, expression contact sheets, a self-contained HTML
page with its Markdown twin, run-to-run comparison (`compare`), paired timing verdicts of two commits
measured side by side (`compare_measurement`, ``harness compare --commits``), timings across commits with
their steps and a dashboard (``harness track``: `detect_steps`), and solver benchmark
summaries across instances: shifted geometric means, outcome counts, wins and Dolan-More performance
profiles (`solve_outcomes`, `performance_profile`).

Everything here reads a run's records (`harness.read_records`); solver results are never recomputed.

Names are imported from their modules on first use (PEP 562), so that ``harness --help``, which lists the
``report``, ``compare`` and ``show`` commands, starts without importing pandas or matplotlib.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import lazy_loader

if TYPE_CHECKING:
    from reports._ab import ABComparison, CaseVerdict, compare_measurement
    from reports._agreement import AGREEMENT_COLUMNS, agreement_counts
    from reports._claims import claims_table
    from reports._compare import Change, Comparison, compare, comparison_table
    from reports._contact import contact_sheet
    from reports._figures import (
        coverage_figure,
        distribution_figure,
        profile_figure,
        rms_figure,
    )
    from reports._gate import Accepted, read_accepted
    from reports._paired import PairedTest, judge, paired_test
    from reports._paper import PAPER_AGREEMENT, PAPER_TIMINGS
    from reports._png import png_bytes
    from reports._report import build_report
    from reports._steps import Step, commit_series, detect_steps
    from reports._summary import (
        SHIFT,
        common_table,
        common_times,
        outcome_table,
        performance_profile,
        performance_ratios,
        sequence_table,
        shifted_geometric_mean,
        solve_outcomes,
        wins,
    )
    from reports._tables import (
        BASELINE_SOLVER,
        REFERENCE_TRANSFERS,
        agreement_table,
        cell_times,
        expression_count_table,
        problem_table,
        rms_table,
        separation_table,
        timing_table,
        worst_shapes_table,
    )

__getattr__, __dir__, __all__ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "_agreement": ["AGREEMENT_COLUMNS", "agreement_counts"],
        "_claims": ["claims_table"],
        "_ab": ["ABComparison", "CaseVerdict", "compare_measurement"],
        "_compare": ["Change", "Comparison", "compare", "comparison_table"],
        "_contact": ["contact_sheet"],
        "_figures": [
            "coverage_figure",
            "distribution_figure",
            "profile_figure",
            "rms_figure",
        ],
        "_gate": ["Accepted", "read_accepted"],
        "_paired": ["PairedTest", "judge", "paired_test"],
        "_paper": ["PAPER_AGREEMENT", "PAPER_TIMINGS"],
        "_png": ["png_bytes"],
        "_report": ["build_report"],
        "_steps": ["Step", "commit_series", "detect_steps"],
        "_summary": [
            "SHIFT",
            "common_table",
            "common_times",
            "outcome_table",
            "performance_profile",
            "performance_ratios",
            "sequence_table",
            "shifted_geometric_mean",
            "solve_outcomes",
            "wins",
        ],
        "_tables": [
            "BASELINE_SOLVER",
            "REFERENCE_TRANSFERS",
            "cell_times",
            "expression_count_table",
            "agreement_table",
            "problem_table",
            "rms_table",
            "separation_table",
            "timing_table",
            "worst_shapes_table",
        ],
    },
)
