"""A Dask cluster with no worker: ``harness run`` says that it waits for one, and gives up after
``--worker-wait``, the cells lost (``--resume`` runs them), instead of waiting for ever without a word."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

import harness

PROJECT = Path(harness.__file__).resolve().parent.parent


@pytest.fixture
def lonely_scheduler(tmp_path: Path) -> Iterator[str]:
    """The address of a Dask scheduler that no worker joins."""
    pytest.importorskip("distributed")
    address_file = tmp_path / "scheduler.json"
    process = subprocess.Popen(
        [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0"]
        + ["--no-dashboard", "--scheduler-file", str(address_file)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env={**os.environ, "PYTHONPATH": str(PROJECT)},
    )
    try:
        deadline = time.monotonic() + 60
        while not (address_file.is_file() and address_file.stat().st_size > 0):
            assert time.monotonic() < deadline, "the Dask scheduler did not start"
            time.sleep(0.05)
        yield json.loads(address_file.read_text())["address"]
    finally:
        process.kill()
        process.wait()


def test_a_cluster_without_workers_is_waited_for_then_given_up(lonely_scheduler: str, tmp_path: Path) -> None:
    command = [
        sys.executable, "-m", "harness", "run", "--rigs", "tiny", "--warps", "none", "--solvers", "greedy",
        "--transfers", "delta", "--j-values", "2", "--executor", "dask", "--scheduler", lonely_scheduler,
        "--worker-wait", "3s", "--out", str(tmp_path / "out"),
    ]  # fmt: skip
    environment = {**os.environ, "PYTHONPATH": str(PROJECT), "COLUMNS": "250"}
    ran = subprocess.run(command, capture_output=True, text=True, timeout=120, env=environment)
    assert ran.returncode == 1, ran.stderr
    assert f"waiting for a worker to join the Dask cluster at {lonely_scheduler}" in ran.stdout
    assert "giving up after 3s" in ran.stdout
    (line,) = ran.stderr.strip().splitlines()
    assert line.startswith("incomplete: 1 cells lost to the infrastructure (first: no worker joined the Dask")
    assert harness.read_run(tmp_path / "out")["state"] == "incomplete"
