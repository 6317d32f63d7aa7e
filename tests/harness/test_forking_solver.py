"""A solver that forks, both processes answering: the copy never answers, what it leaves behind is ended,
and the solve fails naming the solver, so that ``harness pack`` ends with one line and ``harness run``
records an error, and neither waits for the copy (``| tee`` ends with the command)."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.plugin_distribution import registered_module

_ENTRY_POINTS = """[harness.solvers]
forking = cheating_solvers:ForkingSolver
"""
#: The forked copy lingers 30 s: a command that waits for its streams to close takes that long.
PROMPT = 20.0


@pytest.fixture
def forking(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    yield from registered_module(
        Path(__file__).with_name("cheating_solvers.py"), _ENTRY_POINTS, tmp_path / "site", monkeypatch
    )


def _harness(tmp_path: Path, *arguments: object) -> tuple[subprocess.CompletedProcess, float]:
    """``harness ARGUMENTS`` with its output piped, as ``| tee`` would read it; and how long it took."""
    path = os.pathsep.join([str(Path(__file__).resolve().parents[2]), os.environ["PYTHONPATH"]])
    clock = time.monotonic()
    ran = subprocess.run(
        [sys.executable, "-m", "harness", *map(str, arguments)],
        cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": path, "COLUMNS": "250"},
        capture_output=True,
        text=True,
        timeout=120,
    )
    return ran, time.monotonic() - clock


def test_pack_with_a_forking_solver_fails_in_one_line_at_once(forking, tmp_path: Path) -> None:
    ran, seconds = _harness(tmp_path, "pack", "tiny", "--solver", "forking", "--no-pictures", "--out", "out")
    assert ran.returncode == 2 and seconds < PROMPT, (seconds, ran.stderr)
    (line,) = ran.stderr.strip().splitlines()
    assert line.startswith("error: solver forking failed on expression 1: RuntimeError: it left 1 process")
    assert not (tmp_path / "out" / "expressions.json").exists()


def test_run_with_a_forking_solver_records_an_error_at_once(forking, tmp_path: Path) -> None:
    ran, seconds = _harness(
        tmp_path, "run", "--rigs", "tiny", "--warps", "none", "--solvers", "forking,greedy",
        "--transfers", "delta", "--j-values", "2", "--jobs", "1", "-q", "--out", "out",
    )  # fmt: skip
    assert ran.returncode == 0 and seconds < PROMPT, (seconds, ran.stderr)
    import harness

    cells = harness.read_records(tmp_path / "out").query("kind == 'cell'").set_index("solver")
    assert cells.loc["forking", "status"] == "error" and cells.loc["greedy", "status"] == "ok"
    assert "it left 1 process(es) of its own behind" in cells.loc["forking", "message"]
