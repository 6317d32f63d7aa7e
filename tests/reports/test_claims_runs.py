"""The claims table of a real run: computed from that run's records, in ``harness show`` and the report.

`tests/harness/test_claims.py` checks each rule on constructed records (held, not held, not measured);
here a small grid with the claims' variations runs end to end and the table must match what the records
say, recomputed in the test from the rows themselves.
"""

from __future__ import annotations

import pandas as pd
import pytest
from click.testing import CliRunner

import harness
from harness._grid import CLAIM_VARIATIONS
from harness.cli import cli
from reports._claims import HELD, NOT_HELD, NOT_MEASURED, UNSTABLE, claims_table


@pytest.fixture(scope="module")
def run(tmp_path_factory) -> tuple:
    out = tmp_path_factory.mktemp("claims") / "run"
    config = harness.RunConfig(
        rigs=("arkit52",),
        warps=("big-eyes+character",),
        solvers=("greedy", "cpsat"),
        transfers=("ebfr", "dt", "delta"),
        jmax=6,
        j_values=(2, 4, 6),
        repetitions=2,
        variations=CLAIM_VARIATIONS,
    )
    summary = harness.run_grid(config, out, make_executor=lambda timeout: harness.LocalExecutor(jobs=2))
    assert summary.statuses == {"ok": len(config.cells())}
    return out, harness.read_records(out)


def _ebfr(records: pd.DataFrame, **where: object) -> pd.Series:
    rows = records[(records["kind"] == "transfer") & (records["transfer"] == "ebfr")]
    for column, value in {
        "importance": True,
        "symmetry": True,
        "alpha": 0.5,
        "distortion": "paper",
        **where,
    }.items():
        rows = rows[rows[column] == value]
    return rows.groupby("j")["rms"].median()


def test_the_table_reads_this_runs_records(run):
    _, records = run
    table = claims_table(records).set_index("claim")
    verdicts = set(table["verdict"])
    assert verdicts <= {HELD, NOT_HELD, UNSTABLE, NOT_MEASURED}
    # Every RMS claim has its cells in this grid.
    for claim in table.index:
        if "transfer" in claim or "importance" in claim or "alpha" in claim or "symmetry" in claim:
            assert table.loc[claim, "verdict"] != NOT_MEASURED, claim

    optimal, greedy = _ebfr(records, solver="cpsat"), _ebfr(records, solver="greedy")
    wins = int((optimal < greedy).sum())
    median = float(((optimal - greedy) / greedy).median())
    measured = table.loc["optimal expressions transfer better than greedy's", "measured"]
    assert measured.startswith(f"cpsat below greedy at {wins} of {len(optimal)} (seed, rig, warp, J) points")
    assert f"median difference {median:+.1%}" in measured
    held = wins * 2 > len(optimal) and median < 0
    assert table.loc["optimal expressions transfer better than greedy's", "verdict"] == (
        HELD if held else NOT_HELD
    )

    flat = _ebfr(records, solver="cpsat", importance=False, alpha=0.5)
    wins = int((optimal < flat).sum())
    assert table.loc["importance weights lower the transfer error", "measured"].startswith(
        f"importance below none at {wins} of {len(optimal)}"
    )
    # Coverage is only claimed for the paper's female, male and toon.
    assert table.loc["20 expressions cover most shapes", "verdict"] == NOT_MEASURED


def test_harness_show_prints_the_claims(run, monkeypatch):
    out, records = run
    monkeypatch.setenv("COLUMNS", "250")
    result = CliRunner().invoke(cli, ["show", str(out)])
    assert result.exit_code == 0, result.output
    assert "the paper's claims" in result.output
    table = claims_table(records)
    for claim, verdict in zip(table["claim"], table["verdict"], strict=True):
        line = next(line for line in result.output.splitlines() if claim in line)
        assert verdict in line
    assert "(0." in result.output  # RMS with its ratio to dt
