"""Rig format plugins are checked, never trusted: each way one fails (`format_plugins`) is one line naming
it, the other formats read on, and a plugin's rig is recorded with its whole folder, so ``--resume`` sees a
file it read by its own means change."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.plugin_distribution import write_distribution
from tests.rigs.format_plugins import ENTRY_POINTS

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A site folder holding the format plugins as an installed distribution."""
    folder = tmp_path_factory.mktemp("site")
    write_distribution(folder, "format_plugins", ENTRY_POINTS)
    shutil.copy(Path(__file__).with_name("format_plugins.py"), folder)
    return folder


def harness(site: Path, cwd: Path, *arguments: object) -> subprocess.CompletedProcess:
    environment = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(site)]), "COLUMNS": "200"}
    command = [sys.executable, "-m", "harness", *map(str, arguments)]
    return subprocess.run(command, cwd=cwd, env=environment, capture_output=True, text=True, timeout=120)


def errors(ran: subprocess.CompletedProcess) -> list[str]:
    return [line for line in ran.stderr.splitlines() if line.strip() and not line.startswith("warning: ")]


@pytest.mark.parametrize(
    ("name", "content", "message"),
    [
        (
            "plug.xyz",
            "x",
            "rig format plugin 'claims-raise' (format_plugins:CLAIMS_RAISE) failed recognising it",
        ),
        (
            "r.rai",
            "x",
            "rig format plugin 'raising' (format_plugins:RAISING) failed reading it: RuntimeError",
        ),
        ("d.dic", "x", "rig format plugin 'dict' (format_plugins:DICT) returned dict, not a rigs.Rig"),
        (
            "u.unc",
            "x",
            "rig format plugin 'unchecked' (format_plugins:UNCHECKED) returned a rig that is not valid",
        ),
    ],
)
def test_a_faulty_format_plugin_is_one_line_naming_it(site, tmp_path, name, content, message) -> None:
    (tmp_path / name).write_text(content)
    ran = harness(site, tmp_path, "rigs", "info", name)
    assert ran.returncode == 2 and "Traceback" not in ran.stderr
    assert len(errors(ran)) == 1 and errors(ran)[0].startswith(f"error: {name}: {message}"), ran.stderr


def test_faulty_plugins_never_break_the_other_formats(site, tmp_path) -> None:
    ran = harness(site, tmp_path, "rigs", "convert", "tiny", tmp_path / "tiny.npz")
    assert ran.returncode == 0, ran.stderr
    ran = harness(site, tmp_path, "rigs", "info", tmp_path / "tiny.npz")
    assert ran.returncode == 0 and "tiny" in ran.stdout, ran.stderr
    warned = [line for line in ran.stderr.splitlines() if line.startswith("warning: ")]
    assert (
        "rig format plugin 'npz' (format_plugins:NPZ) takes the name 'npz' of a format already" in warned[0]
    )
    (tmp_path / "empty").mkdir()
    ran = harness(site, tmp_path, "pack", "empty", "--out", tmp_path / "out")
    assert ran.returncode == 2 and errors(ran) == [
        "error: empty: rig format plugin 'claims-raise' (format_plugins:CLAIMS_RAISE) failed recognising it: "
        "RuntimeError: claims exploded"
    ]


def test_resume_sees_a_file_a_plugin_read_by_its_own_means_change(site, tmp_path) -> None:
    rig = tmp_path / "rig"
    rig.mkdir()
    (rig / "face.side").write_text("x")
    (rig / "offset.txt").write_text("0.5")
    run = [
        "run",
        "--rigs",
        rig / "face.side",
        "--warps",
        "none",
        "--solvers",
        "greedy",
        "--transfers",
        "delta",
    ]
    ran = harness(site, tmp_path, *run, "--j-values", "2", "--jobs", "1", "-q", "--out", tmp_path / "out")
    assert ran.returncode == 0, ran.stderr
    (rig / "offset.txt").write_text("0.25")
    ran = harness(site, tmp_path, "run", "--resume", tmp_path / "out", "-q")
    assert ran.returncode == 2 and "offset.txt changed" in errors(ran)[0], ran.stderr
