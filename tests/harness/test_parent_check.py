"""Every answer is checked in the harness's own process, on the rows a worker returned: a solver that
disables the checker in its worker is recorded ``invalid``, in sequence and replay cells alike."""

from __future__ import annotations

from pathlib import Path

import pytest

import harness
from harness._grid import RunConfig
from harness._verify import CellChecker
from tests.plugin_distribution import registered_module

_ENTRY_POINTS = """[harness.solvers]
check-breaker = cheating_solvers:CheckBreaker
"""


@pytest.fixture
def cheats(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """Register the cheating solvers for this process and the harness's workers."""
    yield from registered_module(
        Path(__file__).with_name("cheating_solvers.py"), _ENTRY_POINTS, tmp_path / "site", monkeypatch
    )


def test_a_solver_that_disables_the_checker_in_its_worker_is_recorded_invalid(
    cheats, rig_file: Path, tmp_path: Path
) -> None:
    config = RunConfig(
        rigs=(str(rig_file),), warps=("none",), solvers=("check-breaker", "greedy"), transfers=(), replay=True
    )
    summary = harness.run_grid(
        config, tmp_path / "out", make_executor=lambda timeout: harness.LocalExecutor(jobs=1)
    )
    cells = harness.read_records(tmp_path / "out").query("kind == 'cell'")
    by = {(row.solver, row.mode): row for row in cells.itertuples()}
    assert summary.statuses["invalid"] == 2 and summary.statuses["ok"] >= 1
    for mode in ("sequence", "replay"):
        cheat = by[("check-breaker", mode)]
        assert cheat.status == "invalid" and "the harness's check" in cheat.message, cheat.message
        assert "share" in cheat.message and cheat.worker, cheat.message
        assert by[("greedy", mode)].status == "ok"
    assert (
        not harness.read_records(tmp_path / "out").query("solver == 'check-breaker' and kind != 'cell'").size
    )


def test_rows_that_are_no_cells_records_are_invalid(rig_file: Path) -> None:
    config = RunConfig(rigs=(str(rig_file),), warps=("none",), solvers=("greedy",), transfers=())
    (spec,) = config.cells({})
    check = CellChecker()
    for rows, problem in [
        (None, "expected a list of rows"),
        ([{"kind": "expression"}], "one cell row first"),
        ([{"kind": "cell", "status": "ok", "n_expressions": 3}], "counts 3 expressions"),
    ]:
        (row,) = check(spec, rows)
        assert row["status"] == "invalid" and problem in row["message"], row["message"]
