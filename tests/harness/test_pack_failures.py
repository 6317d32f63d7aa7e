"""A solver that fails during ``harness pack`` ends it with one line naming the solver, the expression and the
reason, and a non-zero exit, whatever the failure: raised, malformed answer, infeasible claim, ``sys.exit`` or
a crash of the process."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.harness.cli_helpers import assert_one_line_error, invoke
from tests.plugin_distribution import registered_module

_ENTRY_POINTS = """[harness.solvers]
fail-raise = failing_solvers:Raising
fail-range = failing_solvers:OutOfRange
fail-twice = failing_solvers:Duplicate
fail-infeasible = failing_solvers:Infeasible
fail-exit = failing_solvers:Exiting
fail-abort = failing_solvers:Aborting
fail-second = failing_solvers:SecondFails
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
