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

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
