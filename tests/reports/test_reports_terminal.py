"""`harness show` and `harness list` read at 80 columns, and piped to a file they are plain text that cuts
nothing."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _harness(*arguments: str, columns: int | None) -> str:
    environment = {**os.environ, "PYTHONPATH": str(ROOT), "NO_COLOR": "1"}
    environment.pop("COLUMNS", None)
    if columns is not None:
        environment["COLUMNS"] = str(columns)
    command = [sys.executable, "-c", "from harness.cli import main; main()", *arguments]
    done = subprocess.run(command, env=environment, capture_output=True, text=True, check=True)
    return done.stdout


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> str:
    """A real run of two rigs, three solvers and two transfers."""
    out = tmp_path_factory.mktemp("run") / "run"
    arguments = [
        "run",
        "--rigs",
        "tiny,arkit52",
        "--warps",
        "big-eyes",
        "--solvers",
        "greedy,cpsat,naive-pulp-cbc",
    ]
    _harness(*arguments, "--transfers", "ebfr,dt", "--out", str(out), "--quiet", columns=None)
    return str(out)


@pytest.mark.parametrize("command", ["show", "list"])
def test_at_80_columns_every_line_fits_and_nothing_is_cut(run, command):
    arguments = ["show", run] if command == "show" else ["list"]
    printed = _harness(*arguments, columns=80)
    assert "…" not in printed
    assert max(len(line) for line in printed.splitlines()) <= 80
    if command == "show":
        assert "naive-pulp-cbc" in printed  # a solver's name is never folded


def test_piped_output_is_plain_text_and_cuts_nothing(run):
    printed = _harness("show", run, columns=None)
    assert "…" not in printed and "\x1b[" not in printed
    assert "optimal expressions transfer better than greedy's" in printed  # one line, not folded
