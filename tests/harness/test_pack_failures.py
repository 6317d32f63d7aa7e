"""A solver that fails during ``harness pack`` ends it with one line naming the solver, the expression and the
reason, and a non-zero exit, whatever the failure: raised, malformed answer, infeasible claim, ``sys.exit`` or
a crash of the process; one that ignores its time limit is stopped by ``--timeout`` and ``--time-limit``."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest

import session._minimum
from tests.harness.cli_helpers import assert_one_line_error, invoke
from tests.harness.minimum_workers import MARK_VARIABLE
from tests.plugin_distribution import registered_module

_ENTRY_POINTS = """[harness.solvers]
fail-raise = failing_solvers:Raising
fail-range = failing_solvers:OutOfRange
fail-twice = failing_solvers:Duplicate
fail-infeasible = failing_solvers:Infeasible
fail-exit = failing_solvers:Exiting
fail-abort = failing_solvers:Aborting
fail-second = failing_solvers:SecondFails
stall = failing_solvers:Stalling
stall-second = failing_solvers:StallingSecond
"""

#: Bound on a pack whose solver never answers (seconds): it must end long before.
PATIENCE = 60.0

#: ``harness pack`` whose ``--minimum`` solves with `tests.harness.minimum_workers.stalling_cover`.
STALLING_MINIMUM = """
import sys
import session._minimum
from harness.cli import main

session._minimum.SOLVE_IN_WORKER = "tests.harness.minimum_workers:stalling_cover"
main(sys.argv[1:])
"""


@pytest.fixture
def failing_plugins(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """Register the failing solvers for this process and the harness's workers."""
    yield from registered_module(
        Path(__file__).with_name("failing_solvers.py"), _ENTRY_POINTS, tmp_path / "site", monkeypatch
    )


@pytest.mark.parametrize(
    ("solver", "reason"),
    [
        ("fail-raise", "RuntimeError: the backend lost its licence"),
        ("fail-range", "MalformedAnswer: items [12] are not items of a problem with"),
        ("fail-twice", "an item is chosen twice: [0, 0]"),
        ("fail-infeasible", "it claims the expression is infeasible"),
        ("fail-exit", "it called sys.exit(3)"),
        ("fail-abort", "its process died (killed by SIGABRT)"),
    ],
)
def test_a_failing_solver_is_one_line_naming_it_and_the_expression(failing_plugins, tmp_path, solver, reason):
    out = tmp_path / "out"
    result = invoke("pack", "tiny", "--solver", solver, "--out", out, "--no-pictures")
    assert_one_line_error(result, f"solver {solver} failed on expression 1: ", reason)
    assert not (out / "expressions.json").exists()


def test_a_failure_after_the_first_expression_names_the_expression(failing_plugins, tmp_path):
    result = invoke("pack", "tiny", "--solver", "fail-second", "--out", tmp_path / "out", "--no-pictures")
    assert_one_line_error(result, "solver fail-second failed on expression 2: RuntimeError: out of memory")


def test_the_solver_works_again_after_its_process_crashed(failing_plugins, tmp_path):
    crashed = invoke("pack", "tiny", "--solver", "fail-abort", "--out", tmp_path / "crashed", "--no-pictures")
    assert_one_line_error(crashed, "its process died")
    again = invoke("pack", "tiny", "--solver", "fail-abort", "--out", tmp_path / "again", "--no-pictures")
    assert_one_line_error(again, "solver fail-abort failed on expression 1: its process died")
    honest = invoke("pack", "tiny", "--solver", "greedy", "--out", tmp_path / "honest", "--no-pictures")
    assert honest.exit_code == 0, honest.output


def test_a_failure_under_refinement_is_as_loud(failing_plugins, tmp_path):
    out = tmp_path / "out"
    result = invoke("pack", "tiny", "--solver", "fail-raise", "--reject", "1:jawOpen", "--out", out)
    assert_one_line_error(result, "solver fail-raise failed on expression 1: RuntimeError: the backend lost")
    assert not out.exists() or not any(out.iterdir())


def _pack_in_a_process(*arguments: object) -> subprocess.CompletedProcess[str]:
    """``harness pack ARGUMENTS`` in a process of its own (a hang fails the test instead of stalling it)."""
    return subprocess.run(
        [sys.executable, "-c", "from harness.cli import main; main()", "pack", *map(str, arguments)],
        capture_output=True,
        text=True,
        timeout=PATIENCE,
        env={**os.environ, "COLUMNS": "250"},
    )


def test_timeout_stops_a_solver_that_ignores_its_limit_before_the_first_expression(failing_plugins, tmp_path):
    out = tmp_path / "out"
    result = _pack_in_a_process("tiny", "--solver", "stall", "--timeout", "3", "--no-pictures", "--out", out)
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "--timeout 3.0s ran out before the first expression was found" in lines[0]
    assert not (out / "expressions.json").exists()


def test_timeout_stops_a_solver_that_ignores_its_limit_and_keeps_what_was_found(failing_plugins, tmp_path):
    out = tmp_path / "out"
    arguments = ("tiny", "--solver", "stall-second", "--timeout", "3", "--no-pictures", "--out", out)
    result = _pack_in_a_process(*arguments)
    assert result.returncode == 0, result.stderr
    document = json.loads((out / "expressions.json").read_text())
    assert len(document["expressions"]) == 1
    assert (
        "stopped by --timeout 3.0s after 1 expressions; the expressions found so far are written"
        in (document["warnings"])
    )


def test_time_limit_stops_a_solver_that_ignores_it_and_says_so(failing_plugins, tmp_path):
    out = tmp_path / "out"
    arguments = ("tiny", "--solver", "stall-second", "--time-limit", "1", "--no-pictures", "--out", out)
    result = _pack_in_a_process(*arguments)
    assert result.returncode == 0, result.stderr
    document = json.loads((out / "expressions.json").read_text())
    assert len(document["expressions"]) == 1
    reasons = " ".join(entry["reason"] for entry in document["excluded"])
    assert "the solver found no expression 2: " in reasons, reasons
    assert "no answer within its time limit of 1s; stopped after" in reasons, reasons


def test_a_solver_that_finds_no_first_expression_fails_the_pack(failing_plugins, tmp_path):
    """Stopped at its time limit before any answer, the solver leaves nothing to scan: one line, exit 2, no
    session written (not an empty session and a zero exit)."""
    out = tmp_path / "out"
    result = _pack_in_a_process(
        "tiny", "--solver", "stall", "--time-limit", "1", "--no-pictures", "--out", out
    )
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "solver stall found no expression for tiny (its first answer: " in lines[0]
    assert "no answer within its time limit of 1s" in lines[0]
    assert not (out / "expressions.json").exists()


@pytest.mark.parametrize(
    ("function", "reason"),
    [
        ("aborting_cover", "its process died (killed by SIGABRT)"),
        ("raising_cover", "RuntimeError: the colouring model is corrupt"),
    ],
)
def test_a_failing_minimum_solve_is_one_line(monkeypatch, tmp_path, function, reason):
    named = f"tests.harness.minimum_workers:{function}"
    monkeypatch.setattr(session._minimum, "SOLVE_IN_WORKER", named)
    out = tmp_path / "out"
    result = invoke("pack", "tiny", "--minimum", "--no-pictures", "--out", out)
    assert_one_line_error(result, "solver cpsat failed on --minimum: ", reason)
    assert not (out / "expressions.json").exists()


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def test_ctrl_c_during_a_minimum_solve_stops_its_worker_and_leaves_the_folder_as_it_was(tmp_path):
    out, mark = tmp_path / "out", tmp_path / "mark"
    arguments = ["pack", "tiny", "--no-pictures", "--out", str(out)]
    assert invoke(*arguments, "--solver", "greedy").exit_code == 0
    before = {path: path.read_bytes() for path in out.rglob("*") if path.is_file()}
    process = subprocess.Popen(
        [sys.executable, "-c", STALLING_MINIMUM, *arguments, "--minimum", "--force"],
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, MARK_VARIABLE: str(mark)},
    )
    try:
        while not mark.exists() or not mark.read_text():
            assert process.poll() is None, process.communicate()[1]
            threading.Event().wait(0.02)
        process.send_signal(signal.SIGINT)
        _, stderr = process.communicate(timeout=PATIENCE)
    finally:
        process.kill()
    assert process.returncode == 128 + signal.SIGINT and "interrupted" in stderr, stderr
    worker = int(mark.read_text())
    for _ in range(int(PATIENCE / 0.05)):
        if not _alive(worker):
            break
        threading.Event().wait(0.05)
    assert not _alive(worker), "the worker of --minimum outlived the pack"
    assert {path: path.read_bytes() for path in out.rglob("*") if path.is_file()} == before


def test_a_plugin_that_calls_sys_exit_in_a_run_is_recorded_as_its_error(failing_plugins, tmp_path):
    """Not a lost worker to be resumed: the plugin's own failure, recorded on the first run."""
    import harness

    out = tmp_path / "run"
    arguments = ["run", "--rigs", "tiny", "--solvers", "fail-exit", "--transfers", "dt", "--j-values", "2"]
    result = invoke(*arguments, "--timeout", "60s", "--quiet", "--out", out)
    records = harness.read_records(out)
    cells = records[records["kind"] == "cell"]
    assert cells["status"].tolist() == ["error"], result.output
    assert cells["message"].tolist() == ["the solver called sys.exit(3)"]
    assert harness.read_run(out)["state"] == "complete"
