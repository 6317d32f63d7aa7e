"""The claims table of a real run: computed from that run's records, in ``harness show`` and the report.

`tests/reports/test_claims.py` checks each rule on constructed records (held, not held, inconclusive, not
measured); here a small grid with the claims' variations runs end to end over three faces and the table must
match what the records say, recomputed in the test from the rows themselves.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from scipy import stats

import harness
from harness._grid import CLAIM_VARIATIONS
from harness.cli import cli
from reports._claims import HELD, INCONCLUSIVE, LEAST_CHANGE, NOT_HELD, NOT_MEASURED, claims_table


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
        seed=(0, 1, 2),
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
    return rows.groupby(["rig_seed", "j"])["rms"].median()


def test_the_table_reads_this_runs_records(run):
    _, records = run
    table = claims_table(records).set_index("claim")
    verdicts = set(table["verdict"])
    assert verdicts <= {HELD, NOT_HELD, INCONCLUSIVE, NOT_MEASURED}
    # Every RMS claim has its cells in this grid.
    for claim in table.index:
        if "transfer" in claim or "importance" in claim or "alpha" in claim or "symmetry" in claim:
            assert table.loc[claim, "verdict"] != NOT_MEASURED, claim

    optimal, greedy = _ebfr(records, solver="cpsat"), _ebfr(records, solver="greedy")
    relative = (optimal - greedy) / greedy
    per_face = relative.groupby(level="rig_seed").median().to_numpy()
    mean = per_face.mean()
    half = stats.t.ppf(0.975, len(per_face) - 1) * per_face.std(ddof=1) / np.sqrt(len(per_face))
    measured = table.loc["optimal expressions transfer better than greedy's", "measured"]
    assert measured.startswith(f"cpsat against greedy: mean over 3 faces {mean:+.1%} (95% interval")
    assert f"lower at {int((relative < 0).sum())} of {len(relative)} (seed, rig, warp, J) points" in measured
    if mean + half <= -LEAST_CHANGE:
        expected = HELD
    elif mean - half > -LEAST_CHANGE:
        expected = NOT_HELD
    else:
        expected = INCONCLUSIVE
    assert table.loc["optimal expressions transfer better than greedy's", "verdict"] == expected

    flat = _ebfr(records, solver="cpsat", importance=False, alpha=0.5)
    assert (
        f"lower at {int((optimal < flat).sum())} of {len(optimal)}"
        in (table.loc["importance weights lower the transfer error", "measured"])
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
