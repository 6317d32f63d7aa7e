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
import rigs
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


def _usd_with_sublayer_and_clip(folder: Path) -> tuple[Path, list[Path]]:
    """``face.usda``, which sublayers ``base.usda`` (the rig) and gives the face mesh a value clip
    ``clip.usda``: the argument and the files it composes."""
    from pxr import Sdf, Usd

    from tests.rigs.test_rig_inputs import _tiny

    rigs.save(_tiny(), folder / "base.usda")
    (folder / "clip.usda").write_bytes((folder / "base.usda").read_bytes())
    path = folder / "face.usda"
    layer = Sdf.Layer.CreateNew(str(path))
    layer.subLayerPaths.append("./base.usda")
    stage = Usd.Stage.Open(layer)
    face = next(prim for prim in stage.Traverse() if prim.GetTypeName() == "Mesh")
    clips = Usd.ClipsAPI(stage.OverridePrim(face.GetPath()))
    clips.SetClipPrimPath(str(face.GetPath()))
    clips.SetClipAssetPaths([Sdf.AssetPath("./clip.usda")])
    clips.SetClipActive([(0, 0)])
    layer.Save()
    return path, [path, folder / "base.usda", folder / "clip.usda"]


def test_a_resume_after_any_file_of_a_usd_rig_changed_is_refused_naming_it(tmp_path, inline) -> None:
    """A USD rig's files are its layers: the one given, its sublayers and its value clips."""
    pytest.importorskip("pxr", reason="usd-core is not installed (the usd extra)")
    from tests.harness.test_resume_guards import _config, _one_line_error, invoke
    from tests.rigs.test_rig_inputs import touch

    argument, files = _usd_with_sublayer_and_clip(tmp_path / "rig")
    out = tmp_path / "out"
    config = _config(argument, solvers=("greedy",), transfers=("delta",))
    harness.run_grid(config, out, make_executor=inline)
    for path in files:
        saved = path.read_bytes()
        touch(path)
        line = _one_line_error(invoke("run", "--resume", out))
        assert f"changed since the run started ({path.name} changed)" in line, line
        path.write_bytes(saved)
    assert harness.run_grid(config, out, make_executor=inline, resume=True).already_done == 1
