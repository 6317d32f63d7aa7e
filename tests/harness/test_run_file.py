"""``run.json`` is checked against one schema on every read, and every reader of records keeps to the cells
of the run's grid, as ``--resume`` does: a part file copied in from another run is no record of this one."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

import harness
from harness._grid import RunConfig
from harness._records import RecordsReadError
from harness.cli import cli


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory, rig_file: Path) -> tuple[Path, Path]:
    """Two finished one-cell runs of the test rig, mu 0.3 and mu 0.2 (greedy, no transfers)."""
    from tests.harness.conftest import InlineExecutor

    folder = tmp_path_factory.mktemp("runs")
    runs = []
    for mu in (0.3, 0.2):
        config = RunConfig(
            rigs=(str(rig_file),), warps=("none",), solvers=("greedy",), transfers=(), mu=(mu,)
        )
        harness.run_grid(config, folder / f"mu{mu}", make_executor=lambda timeout: InlineExecutor())
        runs.append(folder / f"mu{mu}")
    return runs[0], runs[1]


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"config": {"mu": ["abc"]}}, "config.mu must be a list, each a finite number, got ['abc']"),
        ({"config": {"rigs": 5}}, "config.rigs must be a list, each a string, got 5"),
        ({"config": {"time_limit": "fast"}}, "config.time_limit must be a finite number or null, got 'fast'"),
        ({"config": {"regions": {"lip": [1, "2"]}}}, "config.regions must be an object of lists of integers"),
        ({"config": {"nonsense": 1}}, "config has the unknown key 'nonsense'"),
        ({"git": 5}, "git must be an object with a string 'commit' and a true/false 'dirty', got 5"),
        ({"state": "done"}, "state must be one of running, complete, incomplete, interrupted, failed"),
        ({"state": None}, "state must be one of"),
        ({"format": "2"}, "format must be an integer, got '2'"),
        ({"versions": {"solvers": {"greedy": 5}}}, "versions must be an object"),
        ({"resumed": "yesterday"}, "resumed must be a list of times, got 'yesterday'"),
    ],
)
def test_a_run_file_of_the_wrong_types_is_one_line_naming_the_key(
    two_runs, tmp_path: Path, change: dict, message: str
) -> None:
    run = Path(shutil.copytree(two_runs[0], tmp_path / "run"))
    document = json.loads((run / "run.json").read_text())
    for key, value in change.items():
        document[key] = {**document[key], **value} if key == "config" else value
    (run / "run.json").write_text(json.dumps(document))
    with pytest.raises(harness.RunDirectoryError) as refused:
        harness.read_run(run)
    assert str(refused.value).startswith(f"{run / 'run.json'}: ") and message in str(refused.value)
    for command in (["show", str(run)], ["instances", "export", str(run), "--out", str(tmp_path / "mps")]):
        ran = CliRunner().invoke(cli, command)
        assert ran.exit_code == 2 and message in ran.output, ran.output


def test_a_run_file_without_a_state_or_config_is_refused(two_runs, tmp_path: Path) -> None:
    run = Path(shutil.copytree(two_runs[0], tmp_path / "run"))
    document = json.loads((run / "run.json").read_text())
    del document["state"]
    (run / "run.json").write_text(json.dumps(document))
    with pytest.raises(harness.RunDirectoryError, match="it has no 'state'"):
        harness.read_run(run)
    (run / "run.json").write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(harness.RunDirectoryError, match="nested too deeply"):
        harness.read_run(run)


def test_a_part_file_copied_from_another_run_is_refused_by_every_reader(two_runs, tmp_path: Path) -> None:
    run, other = (Path(shutil.copytree(found, tmp_path / found.name)) for found in two_runs)
    (stranger,) = (other / "records").glob("*.parquet")
    shutil.copy(stranger, run / "records" / stranger.name)
    with pytest.raises(RecordsReadError, match=f"{stranger.name}: .*not a cell of this run's grid"):
        harness.read_records(run)
    for command in (["show", str(run)], ["report", str(run)], ["compare", str(other), str(run)]):
        ran = CliRunner().invoke(cli, command)
        assert ran.exit_code == 2, ran.output
        assert "not a cell of this run's grid" in ran.output and "not yet run" not in ran.output, ran.output
    summary = harness.run_grid(None, run, make_executor=lambda timeout: None, resume=True)
    assert list(summary.set_aside.values()) == ["not a cell of this run's grid"]
    assert len(harness.read_records(run).query("kind == 'cell'")) == 1
