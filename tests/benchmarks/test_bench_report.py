"""The report of the paper run stays a page one can open and mail: at most 3 MB (figures at a sensible
resolution, renders as JPEG, no data twice)."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from harness.cli import cli
from reports import build_report

#: Most bytes of the paper run's self-contained HTML report.
MOST_BYTES = 3_000_000


@pytest.mark.slow
def test_the_paper_run_report_is_at_most_3_mb(tmp_path):
    out = tmp_path / "paper"
    arguments = [
        "run",
        "--preset",
        "paper",
        "--solvers",
        "all",
        "--transfers",
        "ebfr,dt",
        "--out",
        str(out),
        "--quiet",
    ]
    assert CliRunner().invoke(cli, arguments).exit_code == 0
    page, _ = build_report(out)
    assert page.stat().st_size <= MOST_BYTES, page.stat().st_size
