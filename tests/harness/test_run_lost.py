"""Cells lost to the infrastructure are no results: no part file, the run ends incomplete, and ``--resume``
runs exactly them."""

from __future__ import annotations

import pandas as pd

import harness
from harness import _executors
from harness._cell import Lost, run_cell
from harness._grid import RunConfig


def _config(rig_file) -> RunConfig:
    return RunConfig(
        rigs=(str(rig_file),),
        warps=("none",),
        solvers=("greedy", "cpsat", "highs"),
        transfers=("ebfr",),
        j_values=(2,),
    )


class LosingExecutor:
    """Runs cells in this process, but loses the cells of one solver."""

    def __init__(self, solver: str) -> None:
        self.solver = solver

    def map(self, cells):
        for spec in cells:
            yield (
                spec,
                Lost("worker process 1 died (killed by SIGKILL)")
                if spec.solver == self.solver
                else run_cell(spec),
            )

    def close(self):
        pass


def test_a_lost_cell_leaves_no_part_and_resume_runs_exactly_it(
    rig_file, tmp_path, inline, comparable
) -> None:
    reference = tmp_path / "reference"
    harness.run_grid(_config(rig_file), reference, make_executor=inline)
    out = tmp_path / "out"
    summary = harness.run_grid(_config(rig_file), out, make_executor=lambda timeout: LosingExecutor("cpsat"))
    assert not summary.complete and summary.statuses == {"ok": 2}
    [(cell, reason)] = summary.lost.items()
    run = harness.read_run(out)
    assert run["state"] == "incomplete" and run["lost"][cell]["reason"] == reason
    assert "cpsat" in run["lost"][cell]["cell"] and cell not in set(harness.read_records(out)["cell"])

    resumed = harness.run_grid(None, out, make_executor=inline, resume=True)
    assert resumed.complete and resumed.already_done == 2 and resumed.statuses == {"ok": 1}
    run = harness.read_run(out)
    assert run["state"] == "complete" and run["lost"] == {}
    pd.testing.assert_frame_equal(
        comparable(harness.read_records(out)), comparable(harness.read_records(reference))
    )


def test_a_worker_slower_to_start_than_its_allowance_is_lost_not_timed_out(rig_file, monkeypatch) -> None:
    monkeypatch.setattr(_executors, "STARTUP_ALLOWANCE", 0.0)
    [spec] = RunConfig(rigs=(str(rig_file),), warps=("none",), solvers=("greedy",), transfers=()).cells()
    executor = harness.LocalExecutor(jobs=1, timeout=0.05)
    try:
        [(_, outcome)] = list(executor.map([spec]))
    finally:
        executor.close()
    assert outcome == Lost("worker start-up took over 0s")
