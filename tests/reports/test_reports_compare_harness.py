"""End to end: `harness run` with plugins that sleep or drop a shape, then `harness report` and `compare`.

The probe plugins (`probe_solvers.py`) are registered through a distribution's ``entry_points.txt`` placed
on ``sys.path``, exactly as an installed third-party plugin would be, without installing anything.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

import solvers
from harness.cli import cli
from reports import compare

_ENTRY_POINTS = """[harness.solvers]
probe-slow = probe_solvers:SlowedGreedy
probe-worse = probe_solvers:WorseGreedy
"""


@pytest.fixture
def probe_plugins(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """Register ``probe-slow`` and ``probe-worse`` for this process and the harness's spawned workers."""
    site = tmp_path / "site"
    info = site / "probe_solvers-0.0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: probe-solvers\nVersion: 0.0\n")
    (info / "entry_points.txt").write_text(_ENTRY_POINTS)
    shutil.copy(Path(__file__).with_name("probe_solvers.py"), site)
    monkeypatch.syspath_prepend(str(site))
    monkeypatch.setenv("PYTHONPATH", str(site))
    solvers.refresh()
    yield
    solvers.refresh()


def _run(out: Path, rig: Path, mode: str, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv("PROBE_SOLVERS", mode)
    arguments = [
        "run", "--rigs", str(rig), "--warps", "none", "--solvers", "naive-pulp-cbc,probe-slow,probe-worse",
        "--transfers", "delta", "--j-values", "1,2", "--jobs", "1", "--quiet", "--out", str(out),
    ]  # fmt: skip
    result = CliRunner().invoke(cli, arguments, catch_exceptions=False)
    assert result.exit_code == 0, result.output
    return out


def test_compare_flags_a_sleeping_and_a_shape_dropping_plugin(
    probe_plugins, face_rig_file, tmp_path, monkeypatch
):
    plain = _run(tmp_path / "plain", face_rig_file, "plain", monkeypatch)
    again = _run(tmp_path / "again", face_rig_file, "plain", monkeypatch)
    degraded = _run(tmp_path / "degraded", face_rig_file, "degraded", monkeypatch)

    assert compare(plain, again).regressions() == []  # identical runs: quality equal, times only warn
    result = CliRunner().invoke(cli, ["compare", str(plain), str(again)])
    assert result.exit_code == 0, result.output

    comparison = compare(plain, degraded)
    slower = {(c.case.rsplit("/", 1)[-1], c.metric) for c in comparison.changes if c.verdict == "slower"}
    assert ("probe-slow", "first expression / naive-pulp-cbc") in slower
    assert ("probe-slow", "sequence / naive-pulp-cbc") in slower
    failing = {(c.case.rsplit("/", 1)[-1], c.metric) for c in comparison.regressions()}
    assert ("probe-worse", "objective per expression") in failing
    assert {solver for solver, _ in failing} == {"probe-worse"}

    result = CliRunner().invoke(cli, ["compare", str(plain), str(degraded), "--only-changes"])
    assert result.exit_code == 1
    assert "probe-worse" in result.output and "FAIL" in result.output

    result = CliRunner().invoke(cli, ["report", str(degraded)])
    assert result.exit_code == 0, result.output
    assert "probe-worse" in (degraded / "report" / "report.md").read_text()
