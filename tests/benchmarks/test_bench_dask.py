"""The paper grid on a Dask cluster the run starts for itself, against the local executor.

Target: ``harness run --preset paper --executor dask --jobs 2`` (a `distributed.LocalCluster` of two
single-threaded worker processes, started by the run) takes at most 1.1x the wall time of
``harness run --preset paper --jobs 2`` on the same machine, and records the same cells. Every run is a
whole ``harness`` process timed in this one benchmark, `REPEATS` of each executor interleaved (local,
Dask, local, Dask: a machine that slows down part-way slows both sides alike), and the ratio is of the best
of each, every sample kept in ``extra_info``; the grid takes about a minute each way on two cores, so it is
``slow`` (``pytest tests/benchmarks/test_bench_dask.py -m slow --benchmark-enable``).
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

import harness

#: Largest wall time of the Dask run over the local run's (the best of each).
DASK_OVER_LOCAL = 1.1
#: Runs of each executor.
REPEATS = 2


def _timed_run(out: Path, *executor: str) -> float:
    """Wall seconds of one ``harness run --preset paper`` process writing into ``out``."""
    command = [sys.executable, "-c", "from harness.cli import main; main()", "run", "--preset", "paper"]
    command += ["--jobs", "2", "--quiet"]
    started = time.perf_counter()
    finished = subprocess.run([*command, *executor, "--out", str(out)], capture_output=True, text=True)
    seconds = time.perf_counter() - started
    assert finished.returncode == 0, finished.stdout + finished.stderr
    return seconds


def _findings(out: Path) -> pd.DataFrame:
    """The records of a run without the columns that change from run to run (`harness.TIMING_COLUMNS`),
    in a canonical row order."""
    records = harness.read_records(out).drop(columns=list(harness.TIMING_COLUMNS))
    return records.sort_values(["cell", "kind", "expression", "transfer", "j"]).reset_index(drop=True)


@pytest.mark.slow
def test_bench_paper_grid_on_a_local_dask_cluster(
    benchmark, speed_target, compiled_project, tmp_path
) -> None:
    pytest.importorskip("distributed")
    if benchmark.disabled:
        pytest.skip("the paper grid is timed only with --benchmark-enable")
    local, dask = [], []

    def dask_run(run: int) -> float:
        return _timed_run(tmp_path / f"dask-{run}", "--executor", "dask")

    for run in range(REPEATS):
        local.append(_timed_run(tmp_path / f"local-{run}"))
        # (the benchmark's own timing is the first Dask run; every run is kept in extra_info)
        dask.append(benchmark.pedantic(dask_run, args=(run,), rounds=1) if run == 0 else dask_run(run))
        pd.testing.assert_frame_equal(
            _findings(tmp_path / f"dask-{run}"), _findings(tmp_path / f"local-{run}")
        )
    benchmark.extra_info.update(local_seconds=local, dask_seconds=dask, repeats=REPEATS)
    speed_target(
        "paper grid: Dask cluster of 2 workers over the local executor [wall, best of each]",
        min(dask) / min(local),
        DASK_OVER_LOCAL,
    )
