"""A baseline stands for HEAD only when made from a clean tree at a commit in HEAD's history."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from harness._environment import git_state
from reports._provenance import provenance
from reports.cli import compare

BASELINE = Path(__file__).resolve().parents[2] / "benchmarks" / "baseline"
HEAD = git_state()["commit"]

pytestmark = pytest.mark.skipif(HEAD is None, reason="not a git checkout: no history to place a baseline in")


def _baseline(tmp_path: Path, git: dict) -> Path:
    run = tmp_path / "baseline"
    shutil.copytree(BASELINE, run)
    document = json.loads((run / "run.json").read_text())
    (run / "run.json").write_text(json.dumps({**document, "git": git}))
    return run


@pytest.mark.parametrize(
    ("git", "stale", "said"),
    [
        ({"commit": HEAD, "dirty": False}, False, "0 commits before HEAD"),
        ({"commit": HEAD, "dirty": True}, True, "from a dirty tree"),
        ({"commit": "0" * 40, "dirty": False}, True, "outside HEAD's history"),
        ({}, True, "an unknown commit"),
    ],
)
def test_a_baseline_is_stale_unless_clean_and_in_heads_history(tmp_path, git, stale, said) -> None:
    found = provenance(_baseline(tmp_path, git))
    assert found.stale is stale
    assert said in found.describe()
    assert ("remake it with" in found.describe()) is stale


@pytest.mark.parametrize(("dirty", "code"), [(False, 0), (True, 1)])
def test_fresh_baseline_fails_a_comparison_with_a_stale_baseline(tmp_path, dirty, code) -> None:
    run = _baseline(tmp_path, {"commit": HEAD, "dirty": dirty})
    result = CliRunner(env={"COLUMNS": "250"}).invoke(compare, [str(run), str(BASELINE), "--fresh-baseline"])
    assert result.exit_code == code, result.output
    assert ("baseline is stale" in " ".join(result.output.split())) is dirty
