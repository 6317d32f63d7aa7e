"""Fault injection on real processes: kill -9 and Ctrl-C of the run, a worker killed mid-cell, the Dask
scheduler killed, a full disk. Each keeps every finished cell, and ``--resume`` completes the run to the
records of an uninterrupted one (timing and worker columns aside)."""

from __future__ import annotations

import contextlib
import errno
import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

import harness
from harness.cli import cli

psutil = pytest.importorskip("psutil")

CELLS = 6  # 1 rig x 3 solvers x importance on/off
#: Bound on every wait of these tests (seconds); a healthy run of the grid takes a few.
PATIENCE = 60.0


@pytest.fixture(scope="module")
def grid(grid_arguments) -> list[str]:
    """The ``harness run`` arguments of the grid these tests break, with the ``napper`` solver."""
    return grid_arguments("napper")


@pytest.fixture(scope="module")
def reference(grid, module_plugins, tmp_path_factory) -> pd.DataFrame:
    """Records of the grid run once without a fault, by the local executor."""
    out = tmp_path_factory.mktemp("reference") / "out"
    result = CliRunner().invoke(cli, [*grid, "--out", str(out)])
    assert result.exit_code == 0, result.output
    return harness.read_records(out)


@pytest.fixture
def marks(tmp_path, monkeypatch) -> Path:
    """Where napping cells leave their process id; runs started by the test nap 1.5 s."""
    folder = tmp_path / "marks"
    folder.mkdir()
    monkeypatch.setenv("HARNESS_FAULT_MARKS", str(folder))
    monkeypatch.setenv("HARNESS_FAULT_SLEEP", "1.5")
    return folder


def _parts(out: Path) -> list[Path]:
    return sorted((out / "records").glob("*.parquet")) if (out / "records").is_dir() else []


def _start(arguments: list[str]) -> subprocess.Popen:
    command = [sys.executable, "-c", "from harness.cli import main; main()", *arguments]
    return subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=dict(os.environ))


def _wait(condition, what: str, process: subprocess.Popen | None = None) -> None:
    deadline = time.monotonic() + PATIENCE
    while not condition():
        if process is not None and process.poll() is not None:
            _, stderr = process.communicate()
            code = process.returncode
            raise AssertionError(f"the run ended (exit {code}) before {what}: {stderr.decode()}")
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.02)


def _napping(marks: Path, process: subprocess.Popen | None = None) -> int:
    """The process id of the first cell that started its nap."""
    _wait(lambda: any(marks.iterdir()), "a napping cell", process)
    return int(next(marks.iterdir()).name)


def _resume_to_the_reference(out: Path, reference: pd.DataFrame, comparable, monkeypatch, kept: int) -> None:
    monkeypatch.setenv("HARNESS_FAULT_SLEEP", "0")
    result = CliRunner().invoke(cli, ["run", "--resume", str(out), "--jobs", "1", "--quiet"])
    assert result.exit_code == 0, result.output
    assert f"{CELLS} cells ({kept} recorded before)" in " ".join(result.output.split())
    assert harness.read_run(out)["state"] == "complete"
    pd.testing.assert_frame_equal(comparable(harness.read_records(out)), comparable(reference))


def _files(folder: Path) -> list[Path]:
    return [path for path in folder.rglob("*") if path.is_file()]


@pytest.mark.parametrize("stop", [signal.SIGKILL, signal.SIGINT], ids=["kill-9", "ctrl-c"])
def test_the_run_stopped_takes_its_workers_along_and_resumes_to_the_reference(
    stop, grid, check_stopped, reference, comparable, marks, tmp_path, monkeypatch
) -> None:
    out = tmp_path / "out"
    process = _start([*grid, "--out", str(out)])
    _napping(marks, process)
    workers = psutil.Process(process.pid).children(recursive=True)
    assert workers, "the run has no worker process"

    second = CliRunner().invoke(cli, ["run", "--resume", str(out), "--quiet"])
    assert second.exit_code == 2 and len(second.output.strip().splitlines()) == 1, second.output
    assert f"in use by another harness run (pid {process.pid} on " in second.output

    process.send_signal(stop)
    _, stderr = process.communicate(timeout=PATIENCE)
    _, alive = psutil.wait_procs(workers, timeout=5)
    assert not alive, f"workers outlived the run: {alive}"
    assert len(_parts(out)) == 1  # the greedy cell; the napping one was in flight
    check_stopped(process, stderr, out, stop)
    _resume_to_the_reference(out, reference, comparable, monkeypatch, kept=1)


def test_a_worker_killed_mid_cell_loses_only_that_cell_and_resume_runs_it(
    grid, reference, comparable, marks, tmp_path, monkeypatch
) -> None:
    out = tmp_path / "out"
    process = _start([*grid, "--out", str(out)])
    os.kill(_napping(marks, process), signal.SIGKILL)
    _, stderr = process.communicate(timeout=PATIENCE)
    assert process.returncode == 1, stderr.decode()
    assert "incomplete: 1 cells lost to the infrastructure" in " ".join(stderr.decode().split())
    run = harness.read_run(out)
    assert run["state"] == "incomplete" and len(_parts(out)) == CELLS - 1
    [(cell, lost)] = run["lost"].items()
    assert "napper" in lost["cell"] and "died (killed by SIGKILL) while running the cell" in lost["reason"]
    assert cell not in {path.stem for path in _parts(out)}
    _resume_to_the_reference(out, reference, comparable, monkeypatch, kept=CELLS - 1)


@pytest.fixture
def dask_cluster(module_plugins, marks, tmp_path) -> Iterator[tuple[str, subprocess.Popen]]:
    """A Dask scheduler and one single-threaded worker, as processes on 127.0.0.1."""
    pytest.importorskip("distributed")
    address_file = tmp_path / "scheduler.json"
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL, "env": dict(os.environ)}
    scheduler = subprocess.Popen(
        [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0"]
        + ["--no-dashboard", "--scheduler-file", str(address_file)],
        **quiet,
    )
    worker = subprocess.Popen(
        [sys.executable, "-m", "distributed.cli.dask_worker", "--scheduler-file", str(address_file)]
        + ["--nthreads", "1", "--no-nanny", "--no-dashboard", "--host", "127.0.0.1"],
        **quiet,
    )
    try:
        _wait(lambda: address_file.is_file() and address_file.stat().st_size > 0, "the Dask scheduler")
        yield json.loads(address_file.read_text())["address"], scheduler
    finally:
        for process in (worker, scheduler):
            process.kill()
            process.wait()


def test_a_lost_dask_scheduler_ends_the_run_incomplete_and_resume_finishes_it(
    grid, reference, comparable, marks, dask_cluster, tmp_path, monkeypatch
) -> None:
    address, scheduler = dask_cluster
    out = tmp_path / "out"
    process = _start([*grid, "--out", str(out), "--executor", "dask", "--scheduler", address])
    _napping(marks, process)
    scheduler.kill()
    _, stderr = process.communicate(timeout=PATIENCE)
    assert process.returncode == 1, stderr.decode()
    run = harness.read_run(out)
    kept = len(_parts(out))
    assert run["state"] == "incomplete" and len(run["lost"]) == CELLS - kept >= 1
    reasons = {lost["reason"] for lost in run["lost"].values()}
    assert reasons == {"Dask task cancelled (scheduler-connection-lost)"}
    assert f"{CELLS - kept} cells lost to the infrastructure" in " ".join(stderr.decode().split())
    _resume_to_the_reference(out, reference, comparable, monkeypatch, kept=kept)


@pytest.fixture
def small_disk(tmp_path) -> Iterator[Path]:
    """A 2 MB tmpfs (needs the right to mount; skipped otherwise)."""
    mount = tmp_path / "disk"
    mount.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=2m", "tmpfs", str(mount)], capture_output=True)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.decode().strip()}")
    try:
        yield mount
    finally:
        subprocess.run(["umount", str(mount)], check=True)


@contextlib.contextmanager
def _filled(disk: Path) -> Iterator[None]:
    """Fill ``disk`` to the last byte for the duration of the block."""
    filler = disk / "filler"
    with open(filler, "wb", buffering=0) as handle:
        for size in (1 << 16, 1 << 12, 1 << 9, 1):
            try:
                while True:
                    handle.write(b"\0" * size)
            except OSError as error:
                assert error.errno == errno.ENOSPC
    try:
        yield
    finally:
        filler.unlink()


def test_a_full_disk_at_start_is_one_line_naming_the_folder_and_leaves_no_empty_file(
    grid, module_plugins, small_disk
) -> None:
    out = small_disk / "run"
    with _filled(small_disk):
        result = CliRunner().invoke(cli, [*grid, "--out", str(out)])
        assert result.exit_code == 2, result.output
        lines = result.output.strip().splitlines()
        assert len(lines) == 1 and str(out) in lines[0] and "No space left" in lines[0], result.output
        assert "OUT" not in lines[0]
        assert [path for path in _files(small_disk) if path.stat().st_size == 0] == []
        assert _files(small_disk) == [small_disk / "filler"]


def test_a_disk_full_during_the_run_keeps_the_finished_cells_and_resume_finishes_it(
    grid, reference, comparable, marks, small_disk, monkeypatch
) -> None:
    out = small_disk / "run"
    process = _start([*grid, "--out", str(out)])
    _napping(marks, process)
    with _filled(small_disk):
        _, stderr = process.communicate(timeout=PATIENCE)
        message = stderr.decode().strip()
        assert process.returncode == 2 and len(message.splitlines()) == 1, message
        assert str(out) in message and f"harness run --resume {out}" in message and "OUT" not in message
        assert [path for path in _files(small_disk) if path.stat().st_size == 0] == []
        assert len(_parts(out)) == 1 and not [p for p in _files(out) if p.name.endswith(".tmp")]
    _resume_to_the_reference(out, reference, comparable, monkeypatch, kept=1)


def _exits_within(pid: int, seconds: float) -> bool:
    try:
        psutil.Process(pid).wait(timeout=seconds)
    except psutil.NoSuchProcess:
        pass
    except psutil.TimeoutExpired:
        os.kill(pid, signal.SIGKILL)
        return False
    return True


def test_the_isolated_solver_worker_dies_with_its_parent() -> None:
    script = (
        "import time; from solvers._worker import worker; "
        "print(worker('probe').call('os:getpid'), flush=True); time.sleep(60)"
    )
    parent = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE)
    solver_worker = int(parent.stdout.readline())
    parent.kill()
    parent.wait()
    assert _exits_within(solver_worker, 5)


def test_without_the_kernel_signal_the_watchdog_ends_an_orphaned_worker() -> None:
    orphan = (
        "import os, sys, time; sys.platform = 'elsewhere'; "  # no prctl: only the watchdog thread is left
        "from solvers._worker_child import exit_with_parent; exit_with_parent(os.getppid()); time.sleep(60)"
    )
    middle = (
        f"import subprocess, sys, time; child = subprocess.Popen([sys.executable, '-c', {orphan!r}]); "
        "print(child.pid, flush=True); time.sleep(60)"
    )
    parent = subprocess.Popen([sys.executable, "-c", middle], stdout=subprocess.PIPE)
    child = int(parent.stdout.readline())
    time.sleep(0.5)
    parent.kill()
    parent.wait()
    assert _exits_within(child, 5)
