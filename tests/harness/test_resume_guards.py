"""What ``--resume`` and ``--force`` refuse or repair: changed options, a replaced rig, a folder in use,
broken part files, and files the harness did not write."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pandas as pd
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner

import harness
import rigs
from harness import _records
from harness._cell import Lost, run_cell
from harness._grid import RunConfig, digest_key, rig_digest
from harness._run import locked
from harness.cli import cli
from tests.rigs.test_rig_inputs import FORMS as RIG_FORMS, touch


def _config(rig: Path, **changes) -> RunConfig:
    values = {
        "rigs": (str(rig),),
        "warps": ("none",),
        "solvers": ("greedy", "cpsat"),
        "transfers": ("ebfr",),
        "j_values": (2,),
        "time_limit": 10.0,
    }
    return RunConfig(**{**values, **changes})


def _one_line_error(result) -> str:
    lines = result.output.strip().splitlines()
    assert result.exit_code == 2 and len(lines) == 1 and lines[0].startswith("error: "), result.output
    return lines[0]


def invoke(*arguments) -> object:
    return CliRunner().invoke(cli, [str(argument) for argument in arguments])


@pytest.fixture
def finished(rig_file, tmp_path, inline) -> Path:
    """A finished run of two cells on the test sheet (run in this process)."""
    out = tmp_path / "out"
    harness.run_grid(_config(rig_file), out, make_executor=inline)
    return out


def test_resume_refuses_options_other_than_those_of_the_run(finished, rig_file, inline) -> None:
    line = _one_line_error(invoke("run", "--resume", finished, "--solvers", "greedy", "--mu", "0.3"))
    assert "differs from its run.json: --solvers greedy (the run has greedy,cpsat);" in line
    assert "--mu" not in line
    line = _one_line_error(invoke("run", "--resume", finished, "--time-limit", "5s", "--no-symmetry"))
    assert "--symmetry off (the run has on); --time-limit 5.0 (the run has 10.0)" in line
    assert "--preset paper (the run has none)" in _one_line_error(
        invoke("run", "--resume", finished, "--preset", "paper")
    )
    same = invoke(
        "run", "--resume", finished, "--solvers", "greedy,cpsat", "--mu", "0.3", "--jobs", "1", "-q"
    )
    assert same.exit_code == 0 and "2 cells (2 recorded before)" in same.output, same.output
    with pytest.raises(harness.RunDirectoryError, match="--transfers ebfr,dt"):
        harness.run_grid(
            _config(rig_file, transfers=("ebfr", "dt")), finished, make_executor=inline, resume=True
        )
    result = invoke("run", "--resume", finished, "--force")
    assert result.exit_code == 2 and "not both" in result.output


def test_a_rig_replaced_before_resume_is_refused_and_never_mixed(rig_file, tmp_path, inline) -> None:
    rig = tmp_path / "rig.npz"
    shutil.copy(rig_file, rig)
    out = tmp_path / "out"
    harness.run_grid(_config(rig, seed=(0, 1)), out, make_executor=inline)
    before = harness.read_records(out)
    replacement = rigs.generate("tiny")
    rigs.save(replacement, rig)
    line = _one_line_error(invoke("run", "--resume", out))
    assert f"rig {rig} changed since the run started (rig.npz changed)" in line and "restore them" in line
    assert line.count("changed since the run started") == 1  # (one rig file, however many seeds)

    forced = harness.run_grid(_config(rig), out, make_executor=inline, force=True)
    after = harness.read_records(out)
    assert forced.already_done == 0 and set(before["cell"]).isdisjoint(after["cell"])
    assert set(after["rig_digest"]) == {rig_digest(str(rig), 0)} != set(before["rig_digest"])
    assert set(after["n_vertices"]) == {replacement.n_vertices} != set(before["n_vertices"])


def test_a_rig_changed_under_a_running_cell_is_no_result(rig_file, tmp_path) -> None:
    rig = tmp_path / "rig.npz"
    shutil.copy(rig_file, rig)
    [spec] = _config(rig, solvers=("greedy",)).cells({digest_key(str(rig), 0): rig_digest(str(rig), 0)})
    rigs.save(rigs.generate("tiny"), rig)
    outcome = run_cell(spec)
    assert isinstance(outcome, Lost) and f"rig {rig} changed since the run started" in outcome.reason


def test_a_folder_in_use_is_refused_in_one_line(finished) -> None:
    with locked(finished):
        line = _one_line_error(invoke("run", "--resume", finished))
        assert f"{finished} is in use by another harness run (pid " in line
        line = _one_line_error(invoke("run", "--rigs", "tiny", "--out", finished, "--force", "-q"))
        assert "in use by another harness run" in line
    assert harness.read_run(finished)["state"] == "complete"


def test_resume_sets_broken_part_files_aside_and_reruns_their_cells(
    rig_file, tmp_path, inline, comparable
) -> None:
    out = tmp_path / "out"
    config = _config(rig_file, solvers=("greedy", "cpsat", "highs"), importance=(True, False))
    harness.run_grid(config, out, make_executor=inline)
    reference = harness.read_records(out)
    parts = _records.part_files(out)
    truncated, flipped, swapped, source = parts[:4]
    truncated.write_bytes(truncated.read_bytes()[:-100])
    solver = pq.read_table(flipped).column("solver")[0].as_py().encode()
    flipped.write_bytes(flipped.read_bytes().replace(solver, solver[:-1] + b"#", 1))
    shutil.copy(source, swapped)
    stray = _records.part_path(out, "f" * 16)
    _records.write_part(out, "f" * 16, [{"cell": "f" * 16, "kind": "cell", "status": "ok", "message": ""}])

    line = _one_line_error(invoke("show", out))
    assert str(truncated) in line and "--resume" in line

    summary = harness.run_grid(config, out, make_executor=inline, resume=True)
    assert summary.already_done == 6 - 3 and summary.statuses == {"ok": 3}
    reasons = {path.name: reason for path, reason in summary.set_aside.items()}
    assert sorted(reasons) == sorted(path.name for path in (truncated, flipped, swapped, stray))
    assert "unreadable" in reasons[truncated.name] and "CRC" in reasons[flipped.name]
    assert "another cell" in reasons[swapped.name] and "not a cell of this run" in reasons[stray.name]
    assert all(path.is_file() and path.parent == out / "broken-parts" for path in summary.set_aside)
    pd.testing.assert_frame_equal(comparable(harness.read_records(out)), comparable(reference))


def test_force_removes_only_files_the_harness_wrote(rig_file, tmp_path, inline) -> None:
    out = tmp_path / "mine"
    forced = ["run", "--rigs", rig_file, "--warps", "none", "--out", out, "--force", "-q"]
    (out / "data").mkdir(parents=True)
    users = [out / "notes.txt", out / "data" / "points.csv"]
    for path in users:
        path.write_text("the user's")
    for force in ((), ("--force",)):
        line = _one_line_error(
            invoke("run", "--rigs", rig_file, "--warps", "none", "--out", out, "-q", *force)
        )
        assert "is not empty and holds no harness output (data/points.csv, notes.txt)" in line
    assert all(path.read_text() == "the user's" for path in users)
    for path in users:
        path.unlink()
    (out / "data").rmdir()

    harness.run_grid(_config(rig_file), out, make_executor=inline, force=True)
    first = set(_records.part_files(out))
    harness.run_grid(_config(rig_file, solvers=("highs",)), out, make_executor=inline, force=True)
    assert not first & set(_records.part_files(out)) and len(_records.part_files(out)) == 1

    (out / "run.json").unlink()
    (out / "run.json").write_text("the user's now")
    line = _one_line_error(invoke(*forced))
    assert "harness run did not write or that changed since (run.json)" in line
    (out / "run.json").unlink()
    (out / "records" / "keep.parquet").write_text("the user's")
    line = _one_line_error(invoke(*forced))
    assert "harness run did not write or that changed since (records/keep.parquet)" in line
    assert (out / "records" / "keep.parquet").read_text() == "the user's"
    assert len(_records.part_files(out)) == 1


def test_the_run_folder_may_not_lie_inside_a_rig_folder(rig_file, tmp_path, inline) -> None:
    folder = tmp_path / "rig"
    rigs.save(rigs.load(rig_file), folder, format="obj-folder")
    with pytest.raises(harness.RunDirectoryError, match="lies inside the input"):
        harness.run_grid(_config(folder), folder / "results", make_executor=inline)
    assert not (folder / "results").exists()


@pytest.mark.parametrize("form", sorted(RIG_FORMS))
def test_a_resume_after_any_file_of_a_rig_changed_is_refused_naming_it(form, tmp_path, inline) -> None:
    """Each form a rig file takes: every file its read opened is the rig's content."""
    argument, files = RIG_FORMS[form](tmp_path / "rig")
    out = tmp_path / "out"
    config = _config(argument, solvers=("greedy",), transfers=("delta",))
    harness.run_grid(config, out, make_executor=inline)
    for path in files:
        saved = path.read_bytes()
        touch(path)
        line = _one_line_error(invoke("run", "--resume", out))
        named = path.relative_to(tmp_path / "rig").as_posix()
        assert f"changed since the run started ({named} changed)" in line, line
        path.write_bytes(saved)
    assert harness.run_grid(config, out, make_executor=inline, resume=True).already_done == 1


def test_a_resume_with_another_library_or_solver_version_is_refused_naming_it(finished) -> None:
    run = json.loads((finished / "run.json").read_text())
    run["versions"]["highspy"] = "0.9"
    run["versions"]["solvers"]["cpsat"]["version"] = "0.1"
    (finished / "run.json").write_text(json.dumps(run))
    line = _one_line_error(invoke("run", "--resume", finished))
    assert "(the run has 0.9)" in line and line.split("highspy ")[1].startswith("1.")
    assert "solver cpsat " in line and "(the run has 0.1)" in line
