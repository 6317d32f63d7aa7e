"""`harness.run_grid`: records of a small grid, re-verified; skipped, failing and timed-out cells."""

from __future__ import annotations

import json
import os
import tempfile

import pytest

import harness
import packing
import reports
import rigs
from harness import _plugins
from harness._grid import RunConfig
from harness._run import RUN_FILE
from registry import _atomic, _outdir
from reports._timing import timing_samples
from tests.harness.full_disk import FullDisk


def _config(rig_file, **changes) -> RunConfig:
    values = {
        "rigs": (str(rig_file),),
        "warps": ("none",),
        "solvers": ("greedy", "cpsat"),
        "transfers": ("ebfr", "dt"),
        "j_values": (2, 3),
        "time_limit": 10.0,
    }
    return RunConfig(**{**values, **changes})


def _local(jobs: int = 1):
    return lambda timeout: harness.LocalExecutor(jobs=jobs, timeout=timeout)


def test_a_small_grid_records_every_cell_and_every_sequence_passes_the_checker(rig_file, tmp_path) -> None:
    config = _config(rig_file, solvers=("greedy", "cpsat", "highs"), importance=(True, False))
    summary = harness.run_grid(config, tmp_path / "out", make_executor=_local(jobs=2))
    records = harness.read_records(tmp_path / "out")
    assert summary.total == 6 and summary.statuses == {"ok": 6}, set(records["message"].dropna())

    cells = records[records["kind"] == "cell"]
    assert len(cells) == 6 and set(cells["status"]) == {"ok"}
    assert (cells["analysis_time"] > 0).all() and (cells["lower_bound"] >= 1).all()
    rig = rigs.resolve(str(rig_file))
    for cell in cells.itertuples():
        expressions = records[(records["cell"] == cell.cell) & (records["kind"] == "expression")]
        assert list(expressions["expression"]) == list(range(1, cell.n_expressions + 1))
        assert expressions["covered"].iloc[-1] == cell.n_covered == rig.n_shapes
        params = {"mu": cell.mu, "symmetry": bool(cell.symmetry), "importance": bool(cell.importance)}
        packing.check(rig, [{"shapes": s} for s in expressions["shapes"]], **params)
        transfers = records[(records["cell"] == cell.cell) & (records["kind"] == "transfer")]
        j_values = sorted({min(j, cell.n_expressions) for j in (2, 3)})
        expected = [(method, j) for method in ("dt", "ebfr") for j in j_values]
        assert sorted(zip(transfers["transfer"], transfers["j"], strict=True)) == expected
        assert (transfers["status"] == "ok").all() and (transfers["rms"] >= 0).all()

    run = harness.read_run(tmp_path / "out")
    assert run["state"] == "complete" and run["n_cells"] == 6
    assert run["config"]["solvers"] == ["greedy", "cpsat", "highs"]
    assert {"python", "numpy", "ortools", "highspy"} <= set(run["versions"])
    assert run["versions"]["solvers"]["cpsat"]["available"] is True
    assert set(run["machine"]) >= {"hostname", "cpu_count"} and "commit" in run["git"]

    overlap = reports.agreement_counts(harness.read_records(tmp_path / "out"))
    assert set(zip(overlap["solver_a"], overlap["solver_b"], strict=True)) == {
        ("cpsat", "greedy"),
        ("cpsat", "highs"),
        ("greedy", "highs"),
    }
    assert len(overlap) == 3 * 2 * 3  # solver pairs x importance settings x first 5/10/20
    assert (overlap["shared"] <= overlap[["shapes_a", "shapes_b"]].min(axis=1)).all()


def test_an_occupied_output_directory_is_refused_unless_resumed_or_forced(rig_file, tmp_path, inline) -> None:
    config = _config(rig_file, solvers=("greedy",), transfers=())
    harness.run_grid(config, tmp_path, make_executor=inline)
    with pytest.raises(harness.RunDirectoryError, match="already holds a run; use --resume .* --force"):
        harness.run_grid(config, tmp_path, make_executor=inline)
    resumed = harness.run_grid(config, tmp_path, make_executor=inline, resume=True)
    assert resumed.already_done == 1 and not resumed.statuses
    assert json.loads((tmp_path / RUN_FILE).read_text())["resumed"]
    forced = harness.run_grid(
        _config(rig_file, solvers=("greedy", "highs"), transfers=()),
        tmp_path,
        make_executor=inline,
        force=True,
    )
    assert forced.already_done == 0 and forced.statuses == {"ok": 2}
    with pytest.raises(harness.RunDirectoryError, match="holds no run to resume"):
        harness.run_grid(config, tmp_path / "empty", make_executor=_local(), resume=True)


def test_unknown_names_fail_before_anything_runs_and_list_the_valid_ones(rig_file, tmp_path) -> None:
    cases = [
        ({"solvers": ("cpsat", "gurobi")}, r"unknown solver 'gurobi' for --solvers; valid: .*cpsat.*highs"),
        ({"transfers": ("magic",)}, r"unknown transfer 'magic' for --transfers; valid: .*ebfr"),
        ({"rigs": ("nosuchrig",)}, r"unknown rig 'nosuchrig' for --rigs: not a file or folder.*presets:"),
        ({"warps": ("melt",)}, r"unknown warp 'melt' for --warps; valid: .* or none"),
        ({"mu": (0.3, 1.5)}, r"mu must be in \(0, 1\], got 1.5"),
        ({"cap": (None, 0)}, r"max_per_expression must be a positive integer or None, got 0"),
    ]
    for change, message in cases:
        with pytest.raises(ValueError, match=message):
            harness.run_grid(_config(rig_file, **change), tmp_path / "out", make_executor=_local())
        assert not (tmp_path / "out" / "records").exists()


def test_a_raising_solver_is_an_error_and_an_unavailable_one_is_skipped(
    rig_file, tmp_path, test_plugins
) -> None:
    config = _config(rig_file, solvers=("raising", "missing", "greedy"), transfers=("ebfr",))
    summary = harness.run_grid(config, tmp_path, make_executor=_local())
    assert summary.statuses == {"error": 1, "skipped": 1, "ok": 1}
    cells = harness.read_records(tmp_path).query("kind == 'cell'").set_index("solver")
    assert cells.loc["raising", "message"] == (
        "solver error in expression 1: raising: RuntimeError: backend exploded on purpose"
    )
    assert cells.loc["missing", "message"].startswith(
        "solver 'missing' unavailable: package 'harness-test-nothing'"
    )
    assert cells.loc["greedy", "status"] == "ok"
    assert harness.read_run(tmp_path)["versions"]["solvers"]["missing"]["available"] is False


def test_a_cell_over_the_timeout_is_stopped_and_the_run_goes_on(
    rig_file, tmp_path, test_plugins, monkeypatch
) -> None:
    monkeypatch.setenv("HARNESS_TEST_SLEEP", "60")
    config = _config(rig_file, solvers=("sleepy", "greedy"), transfers=(), timeout=2.0)
    summary = harness.run_grid(config, tmp_path, make_executor=_local(jobs=1))
    assert summary.statuses == {"timeout": 1, "ok": 1}
    cells = harness.read_records(tmp_path).query("kind == 'cell'").set_index("solver")
    assert cells.loc["sleepy", "message"] == (
        "cell exceeded --timeout 2s and was stopped before its first expression was finished"
    )
    assert list(harness.read_records(tmp_path).query("solver == 'sleepy'")["kind"]) == ["cell"]


def test_a_timed_out_cell_keeps_the_expressions_it_finished_and_is_not_run_again(
    rig_file, tmp_path, test_plugins, monkeypatch
) -> None:
    journals = tmp_path / "journals"
    journals.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(journals))
    monkeypatch.setenv("HARNESS_TEST_STALL", "60")
    out = tmp_path / "out"
    config = _config(rig_file, solvers=("staller", "greedy"), transfers=("dt",), timeout=2.0)
    summary = harness.run_grid(config, out, make_executor=_local(jobs=1))
    assert summary.statuses == {"timeout": 1, "ok": 1}
    records = harness.read_records(out)
    stopped = records[records["solver"] == "staller"]
    assert list(stopped["kind"]) == ["cell", "expression", "expression"]
    cell = stopped.iloc[0]
    assert cell["status"] == "timeout" and cell["n_expressions"] == 2
    assert cell["message"] == (
        "cell exceeded --timeout 2s and was stopped after 2 expressions "
        "(the sequence was cut there: not checked, no transfers)"
    )
    # The staller is greedy until it stalls: its 2 expressions are greedy's first 2, solved and timed.
    greedy = records[(records["solver"] == "greedy") & (records["kind"] == "expression")].iloc[:2]
    finished = stopped.iloc[1:]
    assert list(finished["expression"]) == [1, 2]
    assert list(finished["objective"]) == pytest.approx(list(greedy["objective"]))
    assert [list(shapes) for shapes in finished["shapes"]] == [list(shapes) for shapes in greedy["shapes"]]
    assert (finished["objective"] > 0).all() and (finished["solve_time"] >= 0).all()
    assert (
        list(finished["covered"]) == list(greedy["covered"])
        and cell["n_covered"] == greedy["covered"].iloc[-1]
    )
    assert set(finished["termination"]) == set(greedy["termination"])
    # Timed, the repetition is charged its timeout at the expression it was stuck in, not left out as fast.
    assert cell["cell_time"] == 2.0 and cell["sequence_time"] == 2.0
    samples = timing_samples(records).query("solver == 'staller'")
    assert list(samples["expression"]) == [1, 2, 3] and samples["termination"].iloc[-1] == "timeout"
    # The first two took their own time; the third is charged the rest of the timeout and, as any solve
    # that did not finish, at least its time limit.
    assert samples["seconds"].iloc[:2].sum() < 2.0 and samples["seconds"].iloc[-1] == config.time_limit
    # ... on the problem greedy solved third (the same shapes chosen before it): the two pair up.
    greedy_samples = timing_samples(records).query("solver == 'greedy'")
    assert samples["prefix"].iloc[-1] == greedy_samples["prefix"].iloc[2]
    assert list(journals.iterdir()) == []
    resumed = harness.run_grid(config, out, make_executor=_local(jobs=1), resume=True)
    assert resumed.already_done == 2 and not resumed.statuses
    assert harness.read_records(out).equals(records)


def test_a_cell_timed_out_after_its_sequence_says_so(rig_file, tmp_path, test_plugins, monkeypatch) -> None:
    monkeypatch.setenv("HARNESS_TEST_TRANSFER_SLEEP", "60")
    out = tmp_path / "out"
    config = _config(rig_file, solvers=("greedy",), transfers=("sluggish",), timeout=3.0)
    assert harness.run_grid(config, out, make_executor=_local(jobs=1)).statuses == {"timeout": 1}
    records = harness.read_records(out)
    cell = records[records["kind"] == "cell"].iloc[0]
    count = int((records["kind"] == "expression").sum())
    assert count == cell["n_expressions"] > 0
    assert cell["message"] == (
        f"cell exceeded --timeout 3s and was stopped after its whole sequence of {count} expressions, "
        "while checking or transferring (no transfers)"
    )
    assert "transfer" not in set(records["kind"])
    # Its sequence had ended: charged what its solves took, nothing for the expression after them.
    expressions = records[records["kind"] == "expression"]
    spent = expressions[["presolve_time", "build_time", "solve_time", "extra_time"]].astype(float).sum().sum()
    assert cell["cell_time"] == 3.0 and cell["sequence_time"] == pytest.approx(spent)
    assert len(timing_samples(records)) == count


def test_a_sequence_the_checker_rejects_is_recorded_invalid_without_results(
    rig_file, tmp_path, monkeypatch, inline
) -> None:
    def reject(pipeline, expressions, **options):
        raise packing.CheckError(
            "'bump0_L' and 'bump1_L' share 3 active vertices", kind="overlap", expression=2
        )

    monkeypatch.setattr(packing.Pipeline, "check", reject)
    summary = harness.run_grid(_config(rig_file, solvers=("greedy",)), tmp_path, make_executor=inline)
    assert summary.statuses == {"invalid": 1}
    records = harness.read_records(tmp_path)
    assert list(records["kind"]) == ["cell"]
    assert (
        records["message"][0] == "CheckError: expression 2: 'bump0_L' and 'bump1_L' share 3 active vertices"
    )


def test_a_full_disk_stops_the_run_with_finished_cells_kept(rig_file, tmp_path, monkeypatch, inline) -> None:
    real = _outdir.atomic_write
    parts = []

    def second_part_hits_a_full_disk(path, data, **options):
        if path.parent.name == "records":
            parts.append(path)
            if len(parts) == 2:
                monkeypatch.setattr(_atomic, "os", FullDisk())
        try:
            return real(path, data, **options)
        finally:
            monkeypatch.setattr(_atomic, "os", os)

    monkeypatch.setattr(_outdir, "atomic_write", second_part_hits_a_full_disk)
    config = _config(rig_file, solvers=("greedy", "highs", "cpsat"), transfers=())
    with pytest.raises(harness.RecordsWriteError, match=r"could not write .*records.*disk full"):
        harness.run_grid(config, tmp_path, make_executor=inline)
    assert [path.name for path in (tmp_path / "records").iterdir()] == [parts[0].name]
    assert harness.read_run(tmp_path)["state"] == "failed"
    monkeypatch.setattr(_outdir, "atomic_write", real)
    resumed = harness.run_grid(config, tmp_path, make_executor=inline, resume=True)
    assert resumed.already_done == 1 and resumed.statuses == {"ok": 2}


def test_expand_names_keeps_order_and_expands_all() -> None:
    known = ["a", "b", "c"]
    assert _plugins.expand_names(["c", "all"], known, "solver", "--solvers") == ("c", "a", "b")
    with pytest.raises(ValueError, match="names no solver"):
        _plugins.expand_names([], known, "solver", "--solvers")
