"""``harness instances export``: MPS files that outside solvers read as the exact backends' model, a MIPLIB
``.solu`` whose values are their optima, and an output folder that follows the manifest rules."""

from __future__ import annotations

import dataclasses
import importlib.metadata
import json
import re
import tomllib
from pathlib import Path

import highspy
import numpy as np
import pytest

import packing
import solvers
from harness import cli as harness_cli
from harness._grid import RunConfig
from tests.harness.cli_helpers import assert_one_line_error, invoke

ROOT = Path(__file__).resolve().parents[2]
ENTRY_POINT = "harness._cli_instances:instances"
#: A MIPLIB .solu line: a value for =opt= and =best=, none for =inf= and =unkn=.
SOLU_LINE = re.compile(
    r"=(?P<status>opt|best)=\s+(?P<name>\S+)\s+(?P<value>\S+)|=(?:inf|unkn)=\s+(?P<bare>\S+)"
)


@pytest.fixture
def registered(monkeypatch: pytest.MonkeyPatch) -> None:
    """``harness instances`` as the installed entry point of pyproject.toml would register it (the venv's
    installed metadata predates the line)."""
    declared = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["entry-points"]
    value = declared["harness.commands"]["instances"]
    found = harness_cli._plugin_entry_points

    def with_instances() -> dict[str, importlib.metadata.EntryPoint]:
        entry = importlib.metadata.EntryPoint("instances", value, harness_cli.COMMANDS_GROUP)
        return {**found(), "instances": entry}

    monkeypatch.setattr(harness_cli, "_plugin_entry_points", with_instances)


def export(*arguments: object):
    return invoke("instances", "export", *arguments)


def read_solu(folder: Path) -> dict[str, tuple[str, float | None]]:
    """Name -> (status, value) of ``folder/instances.solu``, every line checked against the format."""
    rows = {}
    for line in (folder / "instances.solu").read_text().splitlines():
        match = SOLU_LINE.fullmatch(line)
        assert match, f"not a .solu line: {line!r}"
        if match["bare"]:
            rows[match["bare"]] = (line.split()[0].strip("="), None)
        else:
            rows[match["name"]] = (match["status"], float(match["value"]))
    return rows


def solve_file(path: Path) -> tuple[float, object]:
    """HiGHS's optimum of an MPS file as the file says it (sense included), and the sense it read."""
    highs = highspy.Highs()
    highs.setOptionValue("output_flag", False)
    highs.setOptionValue("mip_rel_gap", 0.0)
    highs.setOptionValue("mip_abs_gap", 0.0)
    assert highs.readModel(str(path)) != highspy.HighsStatus.kError
    highs.run()
    assert highs.getModelStatus() == highspy.HighsModelStatus.kOptimal
    return highs.getInfo().objective_function_value, highs.getLp().sense_


def test_pyproject_registers_the_command() -> None:
    declared = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["entry-points"]
    assert declared["harness.commands"]["instances"] == ENTRY_POINT
    command = importlib.metadata.EntryPoint("instances", ENTRY_POINT, harness_cli.COMMANDS_GROUP).load()
    assert "export" in command.commands


@pytest.mark.parametrize(("rig", "extra"), [("tiny", ()), ("arkit52", ("--cap", "6", "--jmax", "6"))])
def test_every_instance_solves_to_its_solu_value(registered, tmp_path: Path, rig: str, extra) -> None:
    out = tmp_path / "instances"
    result = export(rig, "--out", out, *extra)
    assert result.exit_code == 0, result.output
    solu = read_solu(out)
    document = json.loads((out / "instances.json").read_text())
    names = [entry["name"] for entry in document["instances"]]
    assert names == [f"{rig}-e{i:02d}" for i in range(1, len(names) + 1)] and names
    assert list(solu) == names
    assert sorted(path.name for path in out.glob("*.mps")) == sorted(f"{name}.mps" for name in names)
    for entry in document["instances"]:
        status, value = solu[entry["name"]]
        assert status == "opt" and entry["status"] == "opt" and value == entry["value"]
        optimum, sense = solve_file(out / entry["file"])
        assert sense == highspy.ObjSense.kMinimize and "OBJSENSE" not in (out / entry["file"]).read_text()
        assert optimum < 0  # the negated importance: a sense ignored would answer 0
        assert optimum == pytest.approx(value, rel=1e-9, abs=0)
        shapes = [name for names in entry["columns"].values() for name in names]
        assert len(shapes) == len(set(shapes)) and set(entry["chosen"]) <= set(entry["columns"])
    if extra:  # the cap binds on arkit52's first expression: its row is in the file
        assert " cap " in (out / f"{rig}-e01.mps").read_text()


@pytest.mark.filterwarnings("ignore::packing.MissingTargetWarning")
def test_the_files_are_the_models_the_exact_backends_solve(registered, tmp_path: Path) -> None:
    """Instance e02 read back equals the presolved model of the sequence's second subproblem."""
    out = tmp_path / "instances"
    assert export("tiny", "--out", out).exit_code == 0
    import rigs

    rig = rigs.generate("tiny")
    analysis = packing.analyse(rig)
    first = analysis.problem_for()
    chosen = np.array(solvers.get("cpsat").solve(first).items)
    used = [name for i in chosen for name in first.shapes_of([i])]
    second = analysis.next_problem(first, chosen, used)
    model = solvers.CliqueModel.from_problem(second)
    highs = highspy.Highs()
    highs.setOptionValue("output_flag", False)
    highs.readModel(str(out / "tiny-e02.mps"))
    lp = highs.getLp()
    np.testing.assert_allclose(lp.col_cost_, -model.weights, rtol=1e-14)  # minimised, negated
    assert list(lp.col_names_) == [second.item_label(i) for i in range(second.n_items)]
    assert list(lp.row_upper_) == list(model.upper())


CUT_SHORT = """
import dataclasses

import solvers
from solvers.cpsat import CpSatSolver


class CutShortSolver(CpSatSolver):
    \"\"\"CP-SAT's answer, reported as stopped by its time limit.\"\"\"

    name = "cut-short"

    def solve(self, problem, *, time_limit=None, seed=0):
        found = super().solve(problem, time_limit=time_limit, seed=seed)
        return dataclasses.replace(found, termination=solvers.Termination.TIME_LIMIT)
"""


def test_a_time_limited_reference_is_best_not_opt(registered, tmp_path: Path, monkeypatch) -> None:
    # The reference solves in a worker process: the solver is a plugin file the worker loads itself.
    monkeypatch.setenv("HARNESS_PLUGIN_FILES", "[]")
    (tmp_path / "cut_short.py").write_text(CUT_SHORT)
    out = tmp_path / "instances"
    result = export("tiny", "--out", out, "--time-limit", "1s", "--solver", str(tmp_path / "cut_short.py"))
    solvers.refresh()
    assert result.exit_code == 0, result.output
    solu = read_solu(out)
    assert solu and all(status == "best" for status, _ in solu.values())
    assert all(line.startswith("=best= tiny-e") for line in (out / "instances.solu").read_text().splitlines())
    for name, (_, value) in solu.items():
        assert solve_file(out / f"{name}.mps")[0] == pytest.approx(value, rel=1e-9, abs=0)
    document = json.loads((out / "instances.json").read_text())
    assert {entry["termination"] for entry in document["instances"]} == {"time_limit"}


def test_re_export_replaces_only_its_own_files(registered, tmp_path: Path) -> None:
    out = tmp_path / "instances"
    assert export("tiny", "--out", out).exit_code == 0
    before = {path.name: path.read_bytes() for path in out.iterdir() if path.suffix in (".mps", ".solu")}
    assert_one_line_error(export("tiny", "--out", out), "holds a harness instances", "--force")
    again = export("tiny", "--out", out, "--force")
    assert again.exit_code == 0, again.output
    after = {path.name: path.read_bytes() for path in out.iterdir() if path.suffix in (".mps", ".solu")}
    assert after == before  # the same files (instances.json differs in its solve times)
    fewer = export("tiny", "--out", out, "--force", "--jmax", "1")
    assert fewer.exit_code == 0, fewer.output
    assert sorted(path.name for path in out.glob("*.mps")) == ["tiny-e01.mps"]  # its stale files removed
    assert list(read_solu(out)) == ["tiny-e01"]


def test_a_folder_with_foreign_files_is_refused_and_keeps_them(registered, tmp_path: Path) -> None:
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    (out / "tiny-e01.mps").write_text("my own model")
    for force in ((), ("--force",)):
        result = export("tiny", "--out", out, *force)
        assert_one_line_error(result, "not empty and holds no harness output (notes.txt, tiny-e01.mps)")
    assert (out / "notes.txt").read_text() == "mine" and (out / "tiny-e01.mps").read_text() == "my own model"
    for path in list(out.iterdir()):
        path.unlink()
    result = export("tiny", "--out", out, "--force")
    assert result.exit_code == 0, result.output
    assert (out / "instances.solu").is_file()


def test_bad_input_is_one_line(registered, tmp_path: Path) -> None:
    assert_one_line_error(export("nosuchrig", "--out", tmp_path / "a"), "unknown rig 'nosuchrig'")
    afile = tmp_path / "file"
    afile.write_text("x")
    assert_one_line_error(export("tiny", "--out", afile), "exists and is not a folder")
    assert_one_line_error(export("tiny", "--out", tmp_path / "b", "--solver", "gurobix"), "unknown solver")
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


def test_a_run_directory_gives_one_sequence_per_rig_warp_and_setting(registered, tmp_path: Path) -> None:
    run = tmp_path / "run"
    run.mkdir()
    config = RunConfig(
        rigs=("tiny",), warps=("none", "big-eyes"), solvers=("greedy",), transfers=(), symmetry=(True, False)
    )
    (run / "run.json").write_text(json.dumps({"format": 1, "state": "complete", "config": config.to_dict()}))
    assert_one_line_error(export(run, "--out", tmp_path / "x", "--mu", "0.4"), "run directory", "--mu")
    assert_one_line_error(export(run, "--out", tmp_path / "x", "--rig", "female"), "--rig 'female'")
    out = tmp_path / "instances"
    result = export(run, "--out", out)
    assert result.exit_code == 0, result.output
    document = json.loads((out / "instances.json").read_text())
    prefixes = [sequence["prefix"] for sequence in document["sequences"]]
    assert prefixes == ["tiny-none-s1", "tiny-none-s2", "tiny-big-eyes-s1", "tiny-big-eyes-s2"]
    assert [s["params"]["symmetry"] for s in document["sequences"]] == [True, False, True, False]
    solu = read_solu(out)
    assert set(solu) == {entry["name"] for entry in document["instances"]}
    # the warp's target neutral drives the distortion importance (eq. 6): other weights, other values
    assert solu["tiny-none-s1-e01"][1] != solu["tiny-big-eyes-s1-e01"][1]
    for name, (_, value) in solu.items():
        assert solve_file(out / f"{name}.mps")[0] == pytest.approx(value, rel=1e-9, abs=0)


def test_unsafe_item_names_become_numbered_columns() -> None:
    assert solvers.column_names(["jawOpen", "eyeBlink_L+eyeBlink_R"]) == ("jawOpen", "eyeBlink_L+eyeBlink_R")
    assert solvers.column_names(["jaw open", "b"]) == ("x0", "x1")
    assert solvers.column_names(["a", "a"]) == ("x0", "x1")
    assert solvers.column_names(["$a", "b"]) == ("x0", "x1")


def test_solu_lines() -> None:
    assert solvers.solu_line("opt", "a-e01", 0.1 + 0.2) == "=opt=  a-e01  0.30000000000000004"
    assert solvers.solu_line("best", "a-e01", 1.5) == "=best= a-e01  1.5"
    assert solvers.solu_line("inf", "a-e01") == "=inf=  a-e01"
    with pytest.raises(ValueError, match="finite"):
        solvers.solu_line("opt", "a", None)


def _cbc_programs() -> list[tuple[str, str]]:
    """(which, path) of the CBC programs here: PuLP's bundled CBC 2.10.3 and cbcbox's."""
    import pulp

    found = [("pulp's", pulp.PULP_CBC_CMD().path)]
    try:
        import cbcbox
    except ImportError:
        return found
    return [*found, ("cbcbox's", cbcbox.cbc_bin_path())]


def _answers(path: Path) -> dict[str, float]:
    """The optimum every MIP reader here finds for one MPS file, by reader."""
    import os
    import subprocess
    import sys

    from ortools.linear_solver.python import model_builder

    found = {}
    model = model_builder.Model()
    model.import_from_mps_file(str(path))
    for backend in ("sat", "scip", "highs"):
        solver = model_builder.Solver(backend)
        if solver.solver_is_supported():
            assert solver.solve(model) == model_builder.SolveStatus.OPTIMAL
            found[f"ortools {backend}"] = solver.objective_value
    pyscipopt = pytest.importorskip("pyscipopt")
    scip = pyscipopt.Model()
    scip.hideOutput()
    scip.readProblem(str(path))
    scip.optimize()
    assert scip.getObjectiveSense() == "minimize" and scip.getStatus() == "optimal"
    found["pyscipopt"] = scip.getObjVal()
    found["highspy"] = solve_file(path)[0]
    mip = (
        "import mip, sys; m = mip.Model(solver_name=mip.CBC); m.verbose = 0; m.read(sys.argv[1]); "
        "assert m.optimize() == mip.OptimizationStatus.OPTIMAL; print(repr(m.objective_value))"
    )  # python-mip's CBC does not share a process with OR-Tools
    done = subprocess.run(
        [sys.executable, "-c", mip, str(path)], capture_output=True, text=True, env=os.environ
    )
    if "No module named 'mip'" not in done.stderr:
        assert done.returncode == 0, done.stderr
        found["python-mip"] = float(done.stdout.strip().splitlines()[-1])
    for which, program in _cbc_programs():
        printed = subprocess.run(
            [program, str(path), "-solve", "-quit"], capture_output=True, text=True
        ).stdout
        (line,) = [line for line in printed.splitlines() if line.startswith("Objective value:")]
        assert "Optimal solution found" in printed, printed
        found[f"{which} cbc"] = float(line.split(":")[1])
    return found


def test_every_mip_reader_here_finds_the_solu_value(registered, tmp_path: Path) -> None:
    """Each reader, PuLP's CBC 2.10.3 of the base install included (it ignores OBJSENSE), minimises the
    negated importance and reaches the .solu value (CBC's program prints 8 significant digits)."""
    out = tmp_path / "instances"
    assert export("arkit52", "--jmax", "3", "--out", out).exit_code == 0
    for name, (_, value) in read_solu(out).items():
        assert (out / f"{name}.mps").read_text().startswith("* Free MPS")
        answers = _answers(out / f"{name}.mps")
        assert {"pyscipopt", "highspy", "pulp's cbc"} <= set(answers)
        for reader, optimum in answers.items():
            tolerance = 1e-7 if reader.endswith("cbc") else 1e-9
            assert optimum == pytest.approx(value, rel=tolerance, abs=0), (name, reader)


def test_every_cell_field_either_decides_a_sequence_or_is_said_not_to() -> None:
    """A new grid axis must be classified: part of a sequence's identity, or not (a test that fails until
    it is, so that no export keeps one sequence of several without a word)."""
    from harness._grid import CellSpec
    from harness._instances_source import OTHER_FIELDS, SEQUENCE_FIELDS

    names = {field.name for field in dataclasses.fields(CellSpec)}
    assert not set(SEQUENCE_FIELDS) & set(OTHER_FIELDS)
    assert names == set(SEQUENCE_FIELDS) | set(OTHER_FIELDS)


def test_a_run_of_seeds_and_distortions_exports_every_sequence(registered, tmp_path: Path) -> None:
    run = tmp_path / "run"
    run.mkdir()
    config = RunConfig(
        rigs=("tiny",), warps=("big-eyes",), solvers=("greedy",), transfers=(), seed=(0, 1, 2),
        distortion=("paper", "excess"),
    )  # fmt: skip
    (run / "run.json").write_text(json.dumps({"format": 1, "state": "complete", "config": config.to_dict()}))
    out = tmp_path / "instances"
    result = export(run, "--out", out)
    assert result.exit_code == 0, result.output
    sequences = json.loads((out / "instances.json").read_text())["sequences"]
    assert len(sequences) == 6 and len({s["prefix"] for s in sequences}) == 6
    assert {(s["rig_seed"], s["params"]["distortion"]) for s in sequences} == {
        (seed, distortion) for seed in (0, 1, 2) for distortion in ("paper", "excess")
    }
