"""``harness run --replay`` (every solver on one reference sequence's instances) and ``--permutations``."""

from __future__ import annotations

import json

import pandas as pd
import pytest

import harness
import reports
from harness import _records, _replay
from harness._grid import RunConfig
from tests.harness.cli_helpers import invoke

SOLVERS = ("cpsat", "highs", "greedy")


def _local(timeout):
    return harness.LocalExecutor(jobs=1, timeout=timeout)


def _config(**changes) -> RunConfig:
    values = {
        "rigs": ("tiny",),
        "warps": ("big-eyes",),
        "solvers": SOLVERS,
        "transfers": ("dt",),
        "j_values": (2,),
        "time_limit": 10.0,
    }
    return RunConfig(**{**values, **changes})


@pytest.fixture(scope="module")
def replayed(tmp_path_factory):
    out = tmp_path_factory.mktemp("replay") / "out"
    summary = harness.run_grid(_config(replay=True), out, make_executor=_local)
    return summary, harness.read_records(out), out


def test_replay_cells_solve_the_reference_instances(replayed) -> None:
    summary, records, out = replayed
    assert summary.statuses == {"ok": 6}, set(records["message"].dropna())
    assert json.loads((out / "run.json").read_text())["config"]["replay"] is True
    cells = records[records["kind"] == "cell"].set_index("cell")
    assert sorted(cells["mode"]) == ["replay"] * 3 + ["sequence"] * 3
    replay = cells[cells["mode"] == "replay"]
    assert sorted(replay["solver"]) == sorted(SOLVERS)
    expressions = records[(records["kind"] == "expression") & records["cell"].isin(replay.index)]
    assert not (records["cell"].isin(replay.index) & (records["kind"] == "transfer")).any()
    reference = cells[(cells["mode"] == "sequence") & (cells["solver"] == _replay.REFERENCE_SOLVER)]
    count = int(reference["n_expressions"].iloc[0])
    for cell, rows in expressions.groupby("cell"):
        assert list(rows.sort_values("expression")["expression"]) == list(range(1, count + 1)), cell
    by_solver = expressions.pivot(index="expression", columns="solver", values="objective")
    assert by_solver["cpsat"].to_numpy() == pytest.approx(by_solver["highs"].to_numpy(), rel=1e-9)
    assert (by_solver["greedy"] <= by_solver["cpsat"] * (1 + 1e-9)).all()
    # Instance 1 is expression 1 of every sequence; the reference's replay is its sequence.
    sequence_rows = records[(records["kind"] == "expression") & records["cell"].isin(reference.index)]
    assert list(sequence_rows.sort_values("expression")["objective"]) == pytest.approx(
        list(by_solver["cpsat"]), rel=1e-9
    )


def test_replay_leaves_the_sequence_cells_as_they_were(replayed, tmp_path) -> None:
    _, records, _ = replayed
    harness.run_grid(_config(), tmp_path / "plain", make_executor=_local)
    plain = harness.read_records(tmp_path / "plain")
    assert set(plain["mode"]) == {"sequence"}
    sequence = records[records["cell"].isin(plain["cell"])]
    assert set(sequence["cell"]) == set(plain["cell"])
    columns = [c for c in plain.columns if c not in harness.TIMING_COLUMNS]
    left = sequence[columns].sort_values(["cell", "kind", "expression", "j"]).reset_index(drop=True)
    right = plain[columns].sort_values(["cell", "kind", "expression", "j"]).reset_index(drop=True)
    assert left.astype(str).equals(right.astype(str))


def test_replay_groups_apart_from_sequences(replayed) -> None:
    _, records, _ = replayed
    table = reports.agreement_counts(records)
    assert set(table["mode"]) == {"sequence", "replay"}
    assert "mode" in harness.GROUP_COLUMNS and "permutation" in harness.GROUP_COLUMNS


def test_permutations_change_the_order_not_the_optima(tmp_path) -> None:
    result = invoke(
        "run", "--rigs", "tiny", "--warps", "big-eyes", "--solvers", "cpsat", "--transfers", "dt",
        "--j-values", "2", "--permutations", "3", "--jobs", "1", "--out", tmp_path / "out", "--quiet",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    records = harness.read_records(tmp_path / "out")
    cells = records[records["kind"] == "cell"]
    assert sorted(cells["permutation"]) == [0, 1, 2] and cells["cell"].nunique() == 3
    assert set(cells["status"]) == {"ok"}
    expressions = records[records["kind"] == "expression"]
    objectives = expressions.pivot(index="expression", columns="permutation", values="objective")
    for p in (1, 2):
        assert objectives[p].to_numpy() == pytest.approx(objectives[0].to_numpy(), rel=1e-9)


def test_a_replay_and_permutation_run_resumes_to_the_uninterrupted_records(
    tmp_path, inline, comparable
) -> None:
    """Cells lost from a run with replay cells and permuted cells (their part files gone, as after a stop)
    are run again by ``--resume``; the records equal those of the uninterrupted run."""
    config = _config(solvers=("cpsat", "greedy"), replay=True, permutations=2)
    out = tmp_path / "out"
    harness.run_grid(config, out, make_executor=inline)
    reference = harness.read_records(out)
    cells = reference[reference["kind"] == "cell"]
    assert set(cells["mode"]) == {"sequence", "replay"} and set(cells["permutation"]) == {0, 1}
    parts = _records.part_files(out)
    lost = [parts[0], parts[len(parts) // 2], parts[-1]]
    for path in lost:
        path.unlink()

    summary = harness.run_grid(config, out, make_executor=inline, resume=True)
    assert summary.already_done == len(parts) - len(lost)
    assert sum(summary.statuses.values()) == len(lost)
    pd.testing.assert_frame_equal(comparable(harness.read_records(out)), comparable(reference))
