"""Cells on a real Dask cluster: a scheduler and one worker started by the test, the worker in a folder of its
own and without the test solver plugins. A rig given by a relative path reaches the worker as content (the
worker could not open the path), and a cell the worker cannot set up is lost: the run ends incomplete with
exit code 1, never with an ``error`` cell in a complete run. A cluster of two worker processes, given with
--scheduler or started by the run itself, records what the local executor does; cells are handed to the
workers rig group by rig group, and the cluster a run starts gives its workers the environment of local
ones."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

import harness
from harness import _executors
from harness._cell import CellSetupError, Lost, set_up
from harness._executors import _group, _next_cell
from harness._grid import RunConfig, digest_key, rig_digest
from harness.cli import cli

#: Bound on the wait for the scheduler to start (seconds).
PATIENCE = 60.0
PROJECT = Path(harness.__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def scheduler(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """The address of a Dask scheduler with one single-threaded worker, running in an empty folder with only
    this project on its path."""
    pytest.importorskip("distributed")
    folder = tmp_path_factory.mktemp("dask-worker")
    address_file = folder / "scheduler.json"
    options = {
        "stdout": subprocess.DEVNULL,
        "stderr": subprocess.DEVNULL,
        "cwd": folder,
        "env": {**os.environ, "PYTHONPATH": str(PROJECT)},
    }
    processes = [
        subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0"]
            + ["--no-dashboard", "--scheduler-file", str(address_file)],
            **options,
        ),
        subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_worker", "--scheduler-file", str(address_file)]
            + ["--nthreads", "1", "--no-nanny", "--no-dashboard", "--host", "127.0.0.1"],
            **options,
        ),
    ]
    try:
        deadline = time.monotonic() + PATIENCE
        while not (address_file.is_file() and address_file.stat().st_size > 0):
            assert time.monotonic() < deadline, "the Dask scheduler did not start"
            time.sleep(0.05)
        yield json.loads(address_file.read_text())["address"]
    finally:
        for process in reversed(processes):
            process.kill()
            process.wait()


@pytest.mark.parametrize("timeout", [None, 60.0], ids=["in-task", "in-worker-process"])
def test_a_relative_rig_path_reaches_the_dask_worker_as_content(
    scheduler, rig_file, tmp_path, monkeypatch, inline, comparable, timeout
) -> None:
    monkeypatch.chdir(rig_file.parent)
    config = RunConfig(
        rigs=(rig_file.name,),
        warps=("none",),
        solvers=("greedy", "cpsat"),
        transfers=("ebfr",),
        j_values=(2,),
        timeout=timeout,
    )
    harness.run_grid(config, tmp_path / "reference", make_executor=inline)
    summary = harness.run_grid(
        config, tmp_path / "dask", make_executor=lambda limit: harness.DaskExecutor(scheduler, timeout=limit)
    )
    assert summary.complete and summary.statuses == {"ok": 2}, summary
    assert harness.read_run(tmp_path / "dask")["state"] == "complete"
    pd.testing.assert_frame_equal(
        comparable(harness.read_records(tmp_path / "dask")),
        comparable(harness.read_records(tmp_path / "reference")),
    )


def test_a_cell_the_dask_worker_cannot_set_up_is_lost_and_the_run_exits_1(
    scheduler, test_plugins, rig_file, tmp_path
) -> None:
    out = tmp_path / "out"
    arguments = ["run", "--rigs", str(rig_file), "--warps", "none", "--solvers", "greedy,napper"]
    arguments += ["--transfers", "ebfr", "--j-values", "2", "--executor", "dask", "--scheduler", scheduler]
    result = CliRunner().invoke(cli, [*arguments, "--out", str(out), "--quiet"])
    assert result.exit_code == 1, result.output
    run = harness.read_run(out)
    [lost] = run["lost"].values()
    assert run["state"] == "incomplete" and "napper" in lost["cell"]
    assert "CellSetupError" in lost["reason"] and "cannot set the cell up" in lost["reason"], lost
    cells = harness.read_records(out).query("kind == 'cell'")
    assert list(cells["solver"]) == ["greedy"] and list(cells["status"]) == ["ok"]


def test_a_task_that_killed_its_dask_workers_is_a_crash_of_the_cell() -> None:
    distributed = pytest.importorskip("distributed")

    class LastWorker:
        address = "tcp://127.0.0.1:1"

    lost = _executors._dask_failure(distributed.KilledWorker("harness-cell-x", LastWorker(), 3))
    assert lost.crash and lost.reason.startswith("Dask task failed (KilledWorker")
    cancelled = _executors._dask_failure(
        distributed.client.FutureCancelledError("k", "scheduler-connection-lost")
    )
    assert cancelled == Lost("Dask task cancelled (scheduler-connection-lost)")


def test_a_solver_unavailable_on_the_worker_machine_fails_the_set_up(test_plugins, rig_file) -> None:
    [spec] = RunConfig(rigs=(str(rig_file),), warps=("none",), solvers=("missing",), transfers=()).cells()
    with pytest.raises(CellSetupError, match="cannot set the cell up: .*missing is unavailable here"):
        set_up(spec)


def test_a_rig_changed_before_it_is_sent_loses_its_cells(scheduler, rig_file, tmp_path) -> None:
    rig = tmp_path / "sheet.npz"
    rig.write_bytes(rig_file.read_bytes())
    config = RunConfig(rigs=(str(rig),), warps=("none",), solvers=("greedy", "cpsat"), transfers=())
    cells = config.cells({digest_key(str(rig), 0): rig_digest(str(rig), 0)})
    rig.write_bytes(rig.read_bytes() + b"\0")
    executor = harness.DaskExecutor(scheduler)
    try:
        outcomes = [outcome for _, outcome in executor.map(cells)]
    finally:
        executor.close()
    assert len(outcomes) == 2 and all(isinstance(outcome, Lost) for outcome in outcomes)
    assert "changed since the run started" in outcomes[0].reason, outcomes[0]


@pytest.fixture(scope="module")
def two_groups(rig_file: Path) -> list[str]:
    """``harness run`` arguments (but ``--out``) of 4 cells: the test rig as it is and stretched (two rig
    groups), greedy and cpsat, two transfers."""
    return ["run", "--rigs", str(rig_file), "--warps", "none,scale-x1.3", "--solvers", "greedy,cpsat"] + [
        "--transfers", "ebfr,dt", "--j-values", "2,4", "--quiet"
    ]  # fmt: skip


@pytest.fixture(scope="module")
def local_records(two_groups: list[str], tmp_path_factory: pytest.TempPathFactory) -> pd.DataFrame:
    """The records of `two_groups` run by the local executor."""
    out = tmp_path_factory.mktemp("local")
    result = CliRunner().invoke(cli, [*two_groups, "--out", str(out), "--jobs", "1"])
    assert result.exit_code == 0, result.output
    return harness.read_records(out)


def _two_workers_ran(records: pd.DataFrame) -> None:
    """Both worker processes ran cells: each took a rig group of its own first."""
    cells = records.query("kind == 'cell'")
    assert set(cells["status"]) == {"ok"} and len(cells) == 4, cells
    assert cells["worker"].nunique() == 2, cells[["warp", "solver", "worker"]]


def test_a_cluster_of_two_worker_processes_records_what_the_local_executor_does(
    two_groups, local_records, comparable, tmp_path
) -> None:
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2, processes=True, threads_per_worker=1, dashboard_address=":0"
    ) as cluster:
        arguments = [*two_groups, "--out", str(tmp_path), "--executor", "dask"]
        result = CliRunner().invoke(cli, [*arguments, "--scheduler", cluster.scheduler_address])
    assert result.exit_code == 0, result.output
    records = harness.read_records(tmp_path)
    _two_workers_ran(records)
    pd.testing.assert_frame_equal(comparable(records), comparable(local_records))
    execution = harness.read_run(tmp_path)["execution"]
    assert execution["executor"] == "dask" and execution["scheduler"] == cluster.scheduler_address


def test_the_dask_executor_without_a_scheduler_starts_a_cluster_for_the_run(
    two_groups, local_records, comparable, tmp_path
) -> None:
    pytest.importorskip("distributed")
    arguments = [*two_groups, "--out", str(tmp_path), "--executor", "dask", "--jobs", "2"]
    result = CliRunner().invoke(cli, arguments)
    assert result.exit_code == 0, result.output
    records = harness.read_records(tmp_path)
    _two_workers_ran(records)
    pd.testing.assert_frame_equal(comparable(records), comparable(local_records))
    assert harness.read_run(tmp_path)["execution"]["jobs"] == 2


def test_a_scheduler_without_the_dask_executor_is_refused(two_groups, tmp_path) -> None:
    result = CliRunner().invoke(cli, [*two_groups, "--out", str(tmp_path), "--scheduler", "tcp://x:8786"])
    assert result.exit_code == 2 and "--scheduler" in result.output and "--executor dask" in result.output
    assert not tmp_path.joinpath("run.json").exists()


def test_a_worker_keeps_to_its_rig_group_and_a_free_one_takes_a_group_no_one_is_on(rig_file) -> None:
    config = RunConfig(
        rigs=(str(rig_file),),
        warps=("none", "scale-x1.3", "big-eyes"),
        solvers=("greedy", "cpsat"),
        transfers=(),
    )
    queue = config.cells()
    plain, stretched, big_eyes = (_group(queue[index]) for index in (0, 2, 4))
    assert _group(queue[1]) == plain and _group(queue[3]) == stretched
    assert _next_cell(stretched, {plain}, queue) == 2
    assert _next_cell(None, {plain, stretched}, queue) == 4
    assert _next_cell(None, {None}, queue) == 0
    assert _next_cell(big_eyes, {plain, stretched}, queue[:4]) == 0


def test_the_cluster_started_for_a_run_keeps_the_environment_of_local_workers(monkeypatch) -> None:
    distributed = pytest.importorskip("distributed")
    monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_", raising=False)
    monkeypatch.delenv("OMP_NUM_THREADS", raising=False)
    cluster = _executors._local_cluster(1)
    try:
        with distributed.Client(cluster) as client:
            # (a function of the library, not of this module: worker processes need not import the tests)
            seen = {
                name: client.run(os.getenv, name) for name in ("MALLOC_TRIM_THRESHOLD_", "OMP_NUM_THREADS")
            }
    finally:
        cluster.close()
    assert [list(values.values()) for values in seen.values()] == [[None], [None]]
