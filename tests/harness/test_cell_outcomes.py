"""Every cell ends as a result the records name: a false infeasible verdict is ``invalid``, a solver stuck
in its warm-up is a ``timeout``, a worker crashing on a cell twice is ``crashed``; ``--resume`` runs none of
them again unless asked (``retry_failed``)."""

from __future__ import annotations

from pathlib import Path

import pytest

import harness
from harness._grid import RunConfig
from reports._summary import outcome_table, solve_outcomes
from tests.plugin_distribution import registered_module

_ENTRY_POINTS = """[harness.solvers]
liar-infeasible = liar_solvers:InfeasibleLiar
stuck = liar_solvers:StuckSolver
crashing = liar_solvers:CrashingSolver
"""


@pytest.fixture
def liar_plugins(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """Register the liars for this process and the harness's workers."""
    yield from registered_module(
        Path(__file__).with_name("liar_solvers.py"), _ENTRY_POINTS, tmp_path / "site", monkeypatch
    )


@pytest.fixture
def out(tmp_path: Path) -> Path:
    return tmp_path / "out"


def _config(rig_file: Path, *solvers: str, timeout: float | None = None) -> RunConfig:
    return RunConfig(rigs=(str(rig_file),), warps=("none",), solvers=solvers, transfers=(), timeout=timeout)


def _local(timeout: float | None) -> harness.LocalExecutor:
    return harness.LocalExecutor(jobs=1, timeout=timeout)


def _no_executor(timeout: float | None) -> harness.LocalExecutor:
    raise AssertionError("the run has a cell to run")


def _cells(out: Path):
    return harness.read_records(out).query("kind == 'cell'").set_index("solver")


def test_an_infeasible_verdict_with_nothing_chosen_is_invalid(liar_plugins, rig_file, out, inline) -> None:
    summary = harness.run_grid(_config(rig_file, "liar-infeasible", "greedy"), out, make_executor=inline)
    cells = _cells(out)
    assert summary.statuses == {"invalid": 1, "ok": 1}
    assert cells.loc["liar-infeasible", "status"] == "invalid"
    assert "expression 1: the solver answered infeasible" in cells.loc["liar-infeasible", "message"]


def test_a_solver_stuck_in_its_warm_up_is_a_timeout_that_only_retry_failed_runs_again(
    liar_plugins, rig_file, out
) -> None:
    summary = harness.run_grid(_config(rig_file, "stuck", timeout=1.0), out, make_executor=_local)
    assert summary.complete and summary.statuses == {"timeout": 1}
    message = _cells(out).loc["stuck", "message"]
    assert "warm-up" in message and "exceeded --timeout 1s" in message, message
    assert harness.read_run(out)["state"] == "complete"

    resumed = harness.run_grid(None, out, make_executor=_no_executor, resume=True)
    assert resumed.complete and resumed.already_done == 1 and not resumed.statuses
    retried = harness.run_grid(None, out, make_executor=_local, resume=True, retry_failed=True)
    assert retried.already_done == 0 and retried.statuses == {"timeout": 1}


def test_a_worker_crashing_on_a_cell_twice_records_it_crashed_with_the_signal(
    liar_plugins, rig_file, out
) -> None:
    first = harness.run_grid(_config(rig_file, "crashing", "greedy"), out, make_executor=_local)
    [(cell, reason)] = first.lost.items()
    assert first.statuses == {"ok": 1} and not first.complete
    assert "died (killed by SIGSEGV) while warming up" in reason and "crash 1 of 2" in reason, reason
    run = harness.read_run(out)
    assert run["state"] == "incomplete" and run["crashes"][cell]["count"] == 1

    second = harness.run_grid(None, out, make_executor=_local, resume=True)
    assert second.complete and second.statuses == {"crashed": 1}
    crashed = _cells(out).loc["crashing"]
    assert crashed["cell"] == cell and crashed["status"] == "crashed"
    assert crashed["message"] == "its worker process crashed on it 2 times (last: killed by SIGSEGV)"
    run = harness.read_run(out)
    assert run["state"] == "complete" and run["crashes"] == {} and run["lost"] == {}
    outcomes = outcome_table(solve_outcomes(harness.read_records(out), time_limit=1.0)).set_index("solver")
    assert outcomes.loc["crashing", "crashed"] == 1 and outcomes.loc["greedy", "crashed"] == 0

    third = harness.run_grid(None, out, make_executor=_no_executor, resume=True)
    assert third.complete and third.already_done == 2
    retried = harness.run_grid(None, out, make_executor=_local, resume=True, retry_failed=True)
    assert list(retried.lost) == [cell] and "crash 1 of 2" in retried.lost[cell]
    assert _cells(out).loc["crashing", "status"] == "crashed"  # the recorded result stays until replaced


def test_retry_failed_goes_with_resume(rig_file, out, inline) -> None:
    with pytest.raises(harness.RunDirectoryError, match="--retry-failed .* with --resume"):
        harness.run_grid(_config(rig_file, "greedy"), out, make_executor=inline, retry_failed=True)
