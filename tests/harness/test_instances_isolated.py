"""``harness instances export`` solves as ``harness pack`` and a run's cells do, in a worker process of its
own: a solver that ignores ``--time-limit`` is stopped, one that calls ``sys.exit`` fails the export in one
line, and nothing is left half-written."""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from harness.cli import cli
from tests.plugin_distribution import registered_module

_ENTRY_POINTS = """[harness.solvers]
sleeping = cheating_solvers:SleepingSolver
exiting = cheating_solvers:ExitingSolver
"""


@pytest.fixture
def cheats(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    yield from registered_module(
        Path(__file__).with_name("cheating_solvers.py"), _ENTRY_POINTS, tmp_path / "site", monkeypatch
    )


def test_a_solver_that_ignores_the_time_limit_is_stopped(cheats, tmp_path: Path) -> None:
    clock = time.monotonic()
    ran = CliRunner().invoke(
        cli,
        [
            "instances",
            "export",
            "tiny",
            "--solver",
            "sleeping",
            "--time-limit",
            "1s",
            "--out",
            str(tmp_path / "o"),
        ],
    )
    assert ran.exit_code == 0 and time.monotonic() - clock < 30, ran.output
    (instance,) = json.loads((tmp_path / "o" / "instances.json").read_text())["instances"]
    assert instance["status"] == "unkn" and instance["termination"] == "time_limit"


def test_a_solver_that_exits_fails_the_export_in_one_line(cheats, tmp_path: Path) -> None:
    ran = CliRunner().invoke(
        cli, ["instances", "export", "tiny", "--solver", "exiting", "--out", str(tmp_path / "o")]
    )
    assert ran.exit_code == 2, ran.output
    assert (
        ran.output.strip() == "error: reference solver exiting failed in expression 1: it called sys.exit(0)"
    )
    assert not (tmp_path / "o" / "instances.json").exists()
