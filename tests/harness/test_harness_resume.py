"""Interrupted runs resume to the same records; the Dask executor gives the local executor's records."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

import harness
from harness.cli import cli

CELLS = 6  # 1 rig x 3 solvers x importance on/off


@pytest.fixture(scope="module")
def grid(grid_arguments) -> list[str]:
    """The ``harness run`` arguments of the grid these tests interrupt, with the ``sleepy`` solver."""
    return grid_arguments("sleepy")


@pytest.fixture(scope="module")
def slow_sleepy():
    os.environ["HARNESS_TEST_SLEEP"] = "0.3"
    yield
    del os.environ["HARNESS_TEST_SLEEP"]


@pytest.fixture(scope="module")
def reference(grid, module_plugins, slow_sleepy, tmp_path_factory) -> pd.DataFrame:
    """Records of the grid run once without interruption, by the local executor."""
    out = tmp_path_factory.mktemp("reference")
    result = CliRunner().invoke(cli, [*grid, "--out", str(out), "--force"])
    assert result.exit_code == 0, result.output
    return harness.read_records(out)


def _parts(out: Path) -> list[Path]:
    return sorted((out / "records").glob("*.parquet")) if (out / "records").is_dir() else []


@pytest.mark.parametrize("stop", [signal.SIGINT, signal.SIGKILL], ids=["ctrl-c", "crash"])
def test_a_run_stopped_mid_way_resumes_to_the_uninterrupted_records(
    stop, grid, check_stopped, reference, comparable, tmp_path
) -> None:
    out = tmp_path / "out"
    command = [
        sys.executable,
        "-c",
        "from harness.cli import main; main()",
        *grid,
        "--out",
        str(out),
    ]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=dict(os.environ))
    deadline = time.monotonic() + 120
    while not _parts(out) and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    process.send_signal(stop)
    _, stderr = process.communicate(timeout=60)
    recorded = len(_parts(out))
    assert 1 <= recorded < CELLS, f"the run was not stopped mid-way ({recorded} of {CELLS} cells recorded)"
    check_stopped(process, stderr, out, stop)

    result = CliRunner().invoke(cli, ["run", "--resume", str(out), "--jobs", "1", "--quiet"])
    assert result.exit_code == 0, result.output
    assert f"{CELLS} cells ({recorded} recorded before)" in " ".join(result.output.split())
    run = harness.read_run(out)
    assert run["state"] == "complete" and len(run["resumed"]) == 1
    pd.testing.assert_frame_equal(comparable(harness.read_records(out)), comparable(reference))


def test_the_dask_executor_records_what_the_local_one_does(grid, reference, comparable, tmp_path) -> None:
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=1,
        threads_per_worker=1,
        processes=False,
        protocol="tcp",
        host="127.0.0.1",
        dashboard_address=None,
    ) as cluster:
        arguments = [
            *grid,
            "--out",
            str(tmp_path),
            "--executor",
            "dask",
            "--scheduler",
            cluster.scheduler_address,
        ]
        result = CliRunner().invoke(cli, arguments)
    assert result.exit_code == 0, result.output
    records = harness.read_records(tmp_path)
    assert set(records.loc[records["kind"] == "cell", "status"]) == {"ok"}
    pd.testing.assert_frame_equal(comparable(records), comparable(reference))
