"""A run that cannot write never ends as if it had: whichever write the disk fills at, the run either ends
with one error (nothing recorded as finished that is not on disk) or ``run.json`` says how it ended. Tested by
failing every write from the n-th on, for every n, and on a small real file system where the machine lets
the tests mount one."""

from __future__ import annotations

import errno
import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

import harness
from harness._grid import RunConfig
from registry import HarnessError, _atomic

PROJECT = Path(harness.__file__).resolve().parent.parent


class FillingDisk:
    """The `os` module as `registry._atomic` sees it on a disk that is full from the ``full``-th flush on
    (every flush counted in ``flushes``)."""

    def __init__(self, full: int | None) -> None:
        self.full, self.flushes = full, 0

    def __getattr__(self, name: str) -> Any:
        return getattr(os, name)

    def fsync(self, descriptor: int) -> None:
        self.flushes += 1
        if self.full is not None and self.flushes >= self.full:
            raise OSError(errno.ENOSPC, "No space left on device")
        os.fsync(descriptor)


def _run(rig_file: Path, out: Path, inline, disk: FillingDisk, monkeypatch) -> str:
    """Run a two-cell grid on ``disk``; "ok", or the one line it failed with."""
    monkeypatch.setattr(_atomic, "os", disk)
    config = RunConfig(
        rigs=(str(rig_file),), warps=("none",), solvers=("greedy", "greedy-swap"), transfers=()
    )
    try:
        harness.run_grid(config, out, make_executor=inline)
    except (OSError, HarnessError) as error:
        return str(error)
    finally:
        monkeypatch.setattr(_atomic, "os", os)
    return "ok"


def test_a_disk_full_at_any_write_never_leaves_a_run_that_claims_it_ended(
    rig_file: Path, tmp_path: Path, inline, monkeypatch
) -> None:
    clean = FillingDisk(None)
    assert _run(rig_file, tmp_path / "clean", inline, clean, monkeypatch) == "ok"
    for full in range(1, clean.flushes + 1):
        out = tmp_path / f"full-{full}"
        ended = _run(rig_file, out, inline, FillingDisk(full), monkeypatch)
        info = json.loads((out / "run.json").read_text()) if (out / "run.json").is_file() else {}
        if ended == "ok":
            assert info["state"] == "complete" and info["finished"], (full, info.get("state"))
        else:
            assert "\n" not in ended and ("disk full" in ended or "No space left" in ended), (full, ended)
            assert info.get("state") != "complete", (full, ended)


def _mount_small(folder: Path, size: str) -> bool:
    folder.mkdir()
    if os.geteuid() != 0:
        return False
    mounted = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(folder)], capture_output=True
    )
    return mounted.returncode == 0


@pytest.mark.parametrize("size", ["24k", "96k"])
def test_a_run_on_a_small_file_system_ends_in_one_line_or_recorded(
    tmp_path: Path, rig_file: Path, size: str
) -> None:
    disk = tmp_path / "disk"
    if not _mount_small(disk, size):
        pytest.skip("this machine does not let the tests mount a small file system")
    try:
        command = [
            sys.executable, "-m", "harness", "run", "--rigs", str(rig_file), "--warps", "none",
            "--solvers", "greedy,greedy-swap", "--transfers", "delta", "--j-values", "2", "--jobs", "1", "-q",
            "--out", str(disk / "run"),
        ]  # fmt: skip
        environment = {**os.environ, "PYTHONPATH": str(PROJECT), "COLUMNS": "250"}
        ran = subprocess.run(command, capture_output=True, text=True, timeout=120, env=environment)
        info_file = disk / "run" / "run.json"
        info = json.loads(info_file.read_text()) if info_file.is_file() else {}
        if ran.returncode == 0:
            assert info["state"] == "complete" and info["finished"], ran.stdout
        else:
            assert ran.returncode == 2 and "Traceback" not in ran.stderr, ran.stderr
            (line,) = ran.stderr.strip().splitlines()
            assert "disk full" in line or "No space left" in line, line
            assert info.get("state") != "complete"
    finally:
        subprocess.run(["umount", str(disk)], check=True)
