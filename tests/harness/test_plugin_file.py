"""A solver plugin in one file, the README's: ``harness run --solvers ./my_solver.py`` runs it in the
cells' worker processes, records it under its class's ``name`` with the file's digest as its version, finds
it again on ``--resume`` and refuses it changed; a file that is no plugin is one line naming it."""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

import pytest
from click.testing import CliRunner

import harness
import solvers
from harness.cli import cli
from tests.solvers.test_solvers_plugin_recipe import recipe_files
from transfer._registry import TRANSFERS

#: The README's one-file plugin, as the README gives it.
FIRST_FIT = recipe_files()["my_solver.py"]


@pytest.fixture
def folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """A working folder holding ``my_solver.py``; what the tests register is forgotten afterwards."""
    monkeypatch.setenv("HARNESS_PLUGIN_FILES", "[]")
    monkeypatch.chdir(tmp_path)
    (tmp_path / "my_solver.py").write_text(FIRST_FIT)
    yield tmp_path
    solvers.refresh()
    TRANSFERS.refresh()


def run(*arguments: str):
    """``harness run`` of a small grid (the test sheet rig has no eyes to warp)."""
    grid = [] if "--resume" in arguments else ["--warps", "none", "--jmax", "3", "--quiet"]
    return CliRunner().invoke(cli, ["run", *grid, *arguments], catch_exceptions=False)


def test_a_solver_file_runs_in_the_grid_under_its_name(folder: Path, rig_file: Path) -> None:
    result = run("--rigs", str(rig_file), "--solvers", "./my_solver.py,greedy", "--transfers", "dt")
    assert result.exit_code == 0, result.output
    out = folder / "results" / "quick"
    records = harness.read_records(out)
    cells = records[records["kind"] == "cell"].set_index("solver")
    assert cells.loc["my-first-fit", "status"] == "ok"  # verified by the harness's checker, then recorded
    assert (records[records["solver"] == "my-first-fit"]["kind"] == "expression").sum() > 0
    recorded = json.loads((out / "run.json").read_text())["versions"]["solvers"]["my-first-fit"]
    assert recorded["entry_point"] == str(folder / "my_solver.py")
    assert recorded["version"].startswith("0.1.0, file ")


def test_resume_finds_the_file_again_and_refuses_it_changed(
    folder: Path, rig_file: Path, tmp_path_factory, monkeypatch
) -> None:
    out = folder / "out"
    assert run("--rigs", str(rig_file), "--solvers", "./my_solver.py", "--out", str(out)).exit_code == 0
    elsewhere = tmp_path_factory.mktemp("elsewhere")
    monkeypatch.chdir(elsewhere)
    monkeypatch.setenv("HARNESS_PLUGIN_FILES", "[]")  # a new shell: nothing registered
    solvers.refresh()
    resumed = run("--resume", str(out))
    assert resumed.exit_code == 0 and "nothing to do" in resumed.output, resumed.output
    (folder / "my_solver.py").write_text(FIRST_FIT + "\n# changed\n")
    solvers.refresh()
    refused = run("--resume", str(out))
    assert refused.exit_code != 0
    assert (
        "solver my-first-fit 0.1.0, file " in refused.output and "(the run has 0.1.0, file " in refused.output
    )


@pytest.mark.parametrize(
    ("content", "told"),
    [
        ("class Helper:\n    pass\n", "defines no solver class (Helper is not a Solver: it lacks name"),
        ("raise RuntimeError('boom')\n", "cannot be imported: RuntimeError: boom"),
        (
            FIRST_FIT + FIRST_FIT.replace("FirstFit", "Second").replace("my-first", "my-second"),
            "2 solver classes",
        ),
        (
            FIRST_FIT.replace('"my-first-fit"', '"greedy"'),
            "its solver is named 'greedy', as the one of solvers.",
        ),
    ],
)
def test_a_file_that_is_no_solver_is_one_line_naming_it(folder: Path, rig_file: Path, content, told) -> None:
    (folder / "bad.py").write_text(textwrap.dedent(content))
    result = run("--rigs", str(rig_file), "--solvers", "./bad.py", "--out", str(folder / "out"))
    assert result.exit_code != 0 and "Traceback" not in result.output
    assert result.output.startswith("error: ./bad.py: ") and told in result.output, result.output
    assert not (folder / "out").exists()


def test_a_missing_file_is_named(folder: Path, rig_file: Path) -> None:
    result = run("--rigs", str(rig_file), "--solvers", "./absent.py")
    assert result.exit_code != 0 and result.output.startswith("error: ./absent.py: no such solver file")


def test_solvers_has_everything_a_plugin_file_imports() -> None:
    from packing import Termination

    assert solvers.Termination is Termination
