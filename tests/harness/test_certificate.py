"""The cross-solver certificate (`harness._certificate`): instances, the two rules, and a run that marks a
solver plugin lying about its proofs ``inconsistent`` while the honest cells stay ``ok``."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from harness import read_records
from harness._certificate import INCONSISTENT, instance_keys, violations
from harness._grid import GROUP_COLUMNS
from harness.cli import cli
from tests.plugin_distribution import registered_module

_ENTRY_POINTS = """[harness.solvers]
liar-optimal = liar_solvers:OptimalLiar
liar-bound = liar_solvers:BoundLiar
"""


def _rows(
    cell: str, solver: str, sequence: list[tuple[list[str], float, str, float | None]], overlap: float = 0.0
) -> list[dict]:
    group = dict.fromkeys(GROUP_COLUMNS, 0) | {"rig": "tiny", "warp": "none", "cap": None, "jmax": None}
    rows = [{**group, "cell": cell, "kind": "cell", "solver": solver, "status": "ok", "max_overlap": overlap}]
    for number, (shapes, objective, termination, bound) in enumerate(sequence, 1):
        rows.append(
            {
                **group, "cell": cell, "kind": "expression", "solver": solver, "status": "optimal",
                "expression": number, "shapes": shapes, "objective": objective, "termination": termination,
                "bound": bound, "n_chosen": len(shapes),
            }
        )  # fmt: skip
    return rows


def test_sequences_diverging_after_expression_2_share_only_instances_1_and_2():
    a, b, c = "abc"
    first, second = (["s1", "s2"], 1.0, "optimal", 1.0), (["s2", "s1"], 1.0, "optimal", 1.0)
    records = pd.DataFrame(
        _rows(a, "x", [first, (["s3"], 0.5, "optimal", 0.5), (["s4"], 0.2, "optimal", 0.2)])
        + _rows(b, "y", [second, (["s3"], 0.5, "optimal", 0.5), (["s5"], 0.3, "optimal", 0.3)])
        + _rows(c, "z", [second, (["s5"], 0.4, "completed", None), (["s3"], 0.3, "completed", None)])
    )
    expressions = records[records["kind"] == "expression"]
    keys = instance_keys(expressions, dict.fromkeys("abc", 0.0))
    by_cell = {cell: list(keys[expressions["cell"] == cell]) for cell in "abc"}
    assert by_cell["a"] == by_cell["b"]  # the same earlier shapes as sets, in any order: all 3 shared
    assert by_cell["a"][:2] == by_cell["c"][:2]  # c chose otherwise in expression 2
    assert by_cell["a"][2] != by_cell["c"][2]
    assert len(set(keys)) == 4


def test_the_minority_optimal_claim_is_marked_and_without_majority_every_claim():
    two_to_one = pd.DataFrame(
        _rows("a", "x", [(["s1"], 1.0, "optimal", 1.0)])
        + _rows("b", "y", [(["s1"], 1.0 + 1e-13, "optimal", 1.0)])
        + _rows("c", "liar", [(["s2"], 0.9999, "optimal", 0.9999)])
    )
    found = violations(two_to_one)
    assert set(found) == {"c"}
    assert "liar claims the optimum 0.9999" in found["c"][0] and "expression 1" in found["c"][0]
    one_to_one = pd.DataFrame(  # (within the tie-break of 100 shapes: neither packing refutes the other)
        _rows("a", "x", [([f"s{i}" for i in range(100)], 1.0, "optimal", None)])
        + _rows("c", "y", [([f"t{i}" for i in range(100)], 1.0 - 1e-7, "optimal", None)])
    )
    found = violations(one_to_one)
    assert set(found) == {"a", "c"}
    assert "no majority" in found["a"][0]


@pytest.mark.parametrize("bound", [None, "own"])
def test_a_claim_below_another_packing_is_refuted_and_takes_the_honest_claim_down_with_it_no_more(bound):
    """One plugin claiming a low optimum beside the one reference solver is no tie: the reference's
    packing (and greedy's) refute it, so the reference stays ``ok``."""
    liar = 1.68482262651
    records = pd.DataFrame(
        _rows("a", "cpsat", [(["s1", "s2"], 2.39372716262, "optimal", 2.39372716262)])
        + _rows("b", "greedy", [(["s1"], 2.055, "completed", None)])
        + _rows("c", "liar", [(["s3"], liar, "optimal", liar if bound else None)])
    )
    found = violations(records)
    assert set(found) == {"c"}
    assert "liar" in found["c"][0] and "packing reaches 2.39372716262" in found["c"][0]


def test_a_packing_above_a_proved_bound_marks_the_bound():
    records = pd.DataFrame(
        _rows("a", "exact", [(["s1"], 0.8, "time_limit", 0.8 + 5e-10)])
        + _rows("b", "greedy", [(["s2"], 0.9, "completed", None)])
    )
    found = violations(records)
    assert list(found) == ["a"]
    assert "exact proves the bound 0.8" in found["a"][0] and "greedy's packing reaches 0.9" in found["a"][0]
    within = records.assign(objective=records["objective"].where(records["solver"] != "greedy", 0.8 + 1e-9))
    assert violations(within) == {}


def test_a_solver_allowed_to_overlap_solves_other_instances():
    """``greedy-overlap`` packs a relaxation of eq. 3b: its packing above an exact solver's proof, or its
    optimum beside theirs, refutes nothing, and exact solvers are still held to each other."""
    records = pd.DataFrame(
        _rows("a", "exact", [(["s1"], 0.8, "optimal", 0.8)])
        + _rows("b", "greedy-overlap", [(["s1", "s2"], 1.3, "completed", None)], overlap=0.1)
        + _rows("c", "relaxed-exact", [(["s1", "s2"], 1.3, "optimal", 1.3)], overlap=0.1)
    )
    assert violations(records) == {}
    wrong = pd.DataFrame(_rows("d", "other-exact", [(["s2"], 0.7, "optimal", 0.7)]))
    assert set(violations(pd.concat([records, wrong], ignore_index=True))) == {"d"}  # (a's packing refutes d)


@pytest.fixture
def liar_plugins(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """Register the liars for this process and the harness's workers (a dist-info on ``sys.path``)."""
    yield from registered_module(
        Path(__file__).with_name("liar_solvers.py"), _ENTRY_POINTS, tmp_path / "site", monkeypatch
    )


def _run(out: Path, names: str) -> pd.DataFrame:
    arguments = [
        "run", "--rigs", "arkit52", "--warps", "none", "--solvers", names, "--transfers", "delta",
        "--j-values", "1", "--jobs", "1", "--quiet", "--out", str(out),
    ]  # fmt: skip
    result = CliRunner().invoke(cli, arguments, catch_exceptions=False)
    assert result.exit_code == 0, result.output
    records = read_records(out)
    return records[records["kind"] == "cell"].set_index("solver")


def test_a_run_marks_the_optimal_liar_and_keeps_the_honest_exact_solvers(liar_plugins, tmp_path):
    cells = _run(tmp_path / "run", "highs,cpsat,liar-optimal")
    assert cells.loc["liar-optimal", "status"] == INCONSISTENT
    message = cells.loc["liar-optimal", "message"]
    assert "rig arkit52" in message and "expression 1" in message
    assert "liar-optimal claims the optimum" in message and (
        "highs's packing reaches" in message or "cpsat's packing reaches" in message
    )
    assert list(cells.loc[["highs", "cpsat"], "status"]) == ["ok", "ok"]
    alone = _run(tmp_path / "alone", "cpsat,liar-optimal")  # one honest exact solver: no tie either
    assert alone.loc["liar-optimal", "status"] == INCONSISTENT and alone.loc["cpsat", "status"] == "ok"
    records = read_records(tmp_path / "run")
    liar = cells.loc["liar-optimal", "cell"]
    assert (records["cell"] == liar).sum() == 1  # like an invalid cell: its cell row alone
    resumed = CliRunner().invoke(cli, ["run", "--quiet", "--resume", str(tmp_path / "run")])
    assert resumed.exit_code == 0, resumed.output  # the rewritten part reads back whole and is kept
    again = read_records(tmp_path / "run")
    assert again[again["kind"] == "cell"].set_index("solver")["status"].to_dict() == {
        "cpsat": "ok", "highs": "ok", "liar-optimal": INCONSISTENT
    }  # fmt: skip


def test_a_run_marks_a_bound_below_a_heuristics_packing(liar_plugins, tmp_path):
    cells = _run(tmp_path / "run", "greedy,liar-bound")
    assert cells.loc["liar-bound", "status"] == INCONSISTENT
    assert "greedy's packing reaches" in cells.loc["liar-bound", "message"]
    assert cells.loc["greedy", "status"] == "ok"
