"""A plugin's ``availability()`` gets a time limit: one that does not answer is listed unavailable, saying
so, and neither ``harness list`` nor a run of every solver waits for it."""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

import solvers
from harness.cli import cli
from registry import _registry
from tests.plugin_distribution import registered_module

_ENTRY_POINTS = """[harness.solvers]
silent = cheating_solvers:SilentAvailability
"""


@pytest.fixture
def silent(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setattr(_registry, "PROBE_SECONDS", 0.5)
    yield from registered_module(
        Path(__file__).with_name("cheating_solvers.py"), _ENTRY_POINTS, tmp_path / "site", monkeypatch
    )


def test_a_plugin_that_does_not_say_whether_it_is_available_is_unavailable(silent) -> None:
    clock = time.monotonic()
    found = solvers.availability("silent")
    again = solvers.availability("silent")  # (not asked again)
    assert not found and found is again and time.monotonic() - clock < 5
    assert found.reason == "silent.availability() did not answer within 0.5 s"


def test_harness_list_and_a_run_of_every_solver_do_not_wait_for_it(silent, tmp_path: Path) -> None:
    clock = time.monotonic()
    listed = CliRunner().invoke(cli, ["list", "--json"])
    assert listed.exit_code == 0, listed.output
    (row,) = [item for item in json.loads(listed.output)["solvers"] if item["name"] == "silent"]
    assert row["available"] is False and "did not answer within 0.5 s" in row["reason"]
    ran = CliRunner().invoke(
        cli,
        ["run", "--rigs", "tiny", "--warps", "none", "--solvers", "silent,greedy", "--transfers", "delta",
         "--j-values", "2", "--jobs", "1", "-q", "--out", str(tmp_path / "out")],
    )  # fmt: skip
    assert ran.exit_code == 0 and time.monotonic() - clock < 60, ran.output
    assert "silent" in ran.output and "did not answer" in ran.output
