"""Tables of a report: timings (Table 2), overlap (Table 3), expression counts, problems."""

from __future__ import annotations

import re
from pathlib import Path

import pandas as pd
import pytest

import harness
from reports import (
    BASELINE_SOLVER,
    PAPER_AGREEMENT,
    PAPER_TIMINGS,
    agreement_table,
    cell_times,
    expression_count_table,
    problem_table,
    timing_table,
    worst_shapes_table,
)

#: Tables 2 and 3 of the paper, as printed (shipped with the tests, so that they need nothing outside the
#: repository).
PAPER_TABLES = Path(__file__).resolve().parent / "data" / "carrigan-2020-tables-2-3.txt"


def _paper_rows(pattern: str) -> list[tuple[str, ...]]:
    return re.findall(pattern, PAPER_TABLES.read_text(encoding="utf-8"), flags=re.MULTILINE)


def test_paper_timings_are_table_2_of_the_paper():
    rows = _paper_rows(r"^(Male|Toon|Female|DigiDouble) (\d+) (\d+) ([\d.]+)s ([\d.]+)s$")
    parsed = {
        rig.lower(): [int(n), int(k), float(optimal), float(greedy)] for rig, n, k, optimal, greedy in rows
    }
    assert len(parsed) == 4
    assert {rig: PAPER_TIMINGS.loc[rig].tolist() for rig in PAPER_TIMINGS.index} == parsed


def test_paper_overlaps_are_table_3_of_the_paper():
    cell = r"(\d+)/(\d+) \((\d+)\)"
    rows = _paper_rows(rf"^(Male|Toon|Female|DigiDouble) {cell} {cell} {cell}$")
    parsed = {
        (rig.lower(), expressions): [int(v) for v in values[3 * i : 3 * i + 3]]
        for rig, *values in rows
        for i, expressions in enumerate((5, 10, 20))
    }
    assert len(parsed) == 12
    assert {key: PAPER_AGREEMENT.loc[key].tolist() for key in PAPER_AGREEMENT.index} == parsed


def test_cell_times_divide_by_the_baseline_of_the_same_repetition(make_run):
    records = harness.read_records(make_run("run", jitter=0.5))
    times = cell_times(records).set_index(["solver", "repetition"])
    # repetition 1 is 1.5x slower for every solver, so the ratio is the same in both repetitions
    assert times.loc[("highs", 0), "first_time"] == pytest.approx(0.02)
    assert times.loc[("highs", 1), "first_time"] == pytest.approx(0.03)
    assert times.loc[("highs", 0), "first_ratio"] == pytest.approx(0.01)
    assert times.loc[("highs", 1), "first_ratio"] == pytest.approx(0.01)
    assert times.loc[("greedy", 0), "sequence_ratio"] == pytest.approx(0.003 / 6.0)
    assert times.loc[(BASELINE_SOLVER, 0), "first_ratio"] == pytest.approx(1.0)


def test_timing_table_has_median_spread_and_paper_rows(make_run):
    records = harness.read_records(make_run("run", rig="female", n_vertices=5034))
    table = timing_table(records)
    naive = table[table["solver"] == BASELINE_SOLVER].iloc[0]
    assert (naive["N"], naive["K"], naive["repetitions"]) == (5034, 9, 2)
    assert naive["first expression (s)"] == pytest.approx(2.1)  # median of 2.0 and 2.2
    assert naive["first spread (s)"] == pytest.approx(0.2)
    assert naive["sequence (s)"] == pytest.approx(6.3)
    highs = table[table["solver"] == "highs"].iloc[0]
    assert highs[f"first / {BASELINE_SOLVER}"] == pytest.approx(0.01)
    paper = table[table["warp"] == "paper, Table 2"].set_index("solver")
    assert paper.loc["optimal (PuLP + CPLEX)", "first expression (s)"] == 13.14
    assert paper.loc["greedy", ["N", "K", "first expression (s)"]].tolist() == [5034, 265, 0.39]


def test_timing_table_has_no_paper_rows_for_other_rigs(make_run):
    table = timing_table(harness.read_records(make_run("run")))
    assert set(table["solver"]) == {BASELINE_SOLVER, "highs", "cpsat", "greedy"}
    assert "setting" not in table.columns


def test_timing_table_labels_settings_that_vary(make_run):
    table = timing_table(harness.read_records(make_run("run", importance=(True, False))))
    assert sorted(set(table["setting"])) == ["importance off", "importance on"]
    assert len(table) == 8


@pytest.fixture
def male_overlap(group) -> pd.DataFrame:
    """Overlap rows of cpsat and greedy on ``male`` as Table 3 gives them, and one of a second repetition."""
    row = {
        **group("male"),
        "solver_a": "cpsat",
        "solver_b": "greedy",
        "expressions_a": 5,
        "expressions_b": 5,
    }
    rows = [
        {**row, "first": 5, "shapes_a": 38, "shapes_b": 36, "shared": 31},
        {
            **row,
            "first": 10,
            "shapes_a": 49,
            "shapes_b": 49,
            "shared": 42,
            "expressions_a": 10,
            "expressions_b": 10,
        },
        {
            **row,
            "first": 20,
            "shapes_a": 60,
            "shapes_b": 63,
            "shared": 56,
            "expressions_a": 17,
            "expressions_b": 20,
        },
        {**row, "first": 5, "shapes_a": 1, "shapes_b": 1, "shared": 1, "repetition": 1},
    ]
    return pd.DataFrame(rows)


def test_agreement_table_formats_like_table_3_with_the_paper_row(male_overlap):
    table = agreement_table(male_overlap).set_index(["warp", "pair"])
    ours = table.loc[("alien", "cpsat/greedy")]
    assert ours["5 ex."] == "38/36 (31)"  # repetition 1 is not shown
    assert ours["10 ex."] == "49/49 (42)"
    assert ours["20 ex."] == "60/63 (56) [17/20 expr.]"
    paper = table.loc[("paper, Table 3", "greedy/optimal")]
    assert paper.tolist() == ["male", "36/38 (31)", "49/49 (42)", "63/63 (56)"]


def test_agreement_table_of_an_empty_run_is_empty(male_overlap):
    assert agreement_table(male_overlap.iloc[0:0]).empty


def test_expression_count_table_marks_truncated_sequences(make_run):
    records = harness.read_records(make_run("run", lower_bound=2))
    truncated = records["solver"] == "greedy"
    records.loc[truncated & (records["kind"] == "cell"), "n_covered"] = 7
    table = expression_count_table(records).iloc[0]
    assert (table["K"], table["empty"], table["lower bound"]) == (9, 0, 2)
    assert (table["highs"], table["greedy"]) == ("3", "3+")
    assert "minimum" not in table.index


def test_expression_count_table_shows_the_best_recorded_minimum(make_run):
    records = harness.read_records(make_run("run"))
    cells = records["kind"] == "cell"
    records.loc[cells & (records["solver"] == "highs"), ["min_expressions", "min_expressions_status"]] = [
        4,
        "feasible",
    ]
    assert expression_count_table(records).iloc[0]["minimum"] == "<= 4"
    records.loc[cells & (records["solver"] == "cpsat"), ["min_expressions", "min_expressions_status"]] = [
        3,
        "optimal",
    ]
    assert expression_count_table(records).iloc[0]["minimum"] == "3"


def test_problem_table_lists_cells_that_did_not_finish(make_run):
    records = harness.read_records(make_run("run", skipped={"scip": "pyscipopt is not installed"}))
    problems = problem_table(records)
    assert problems.values.tolist() == [["face", "alien", "scip", 2, "skipped", "pyscipopt is not installed"]]


def test_worst_shapes_table_reads_the_largest_j(make_run):
    records = harness.read_records(make_run("run", transfers=("ebfr",)))
    table = worst_shapes_table(records).set_index("solver")
    assert list(table.index) == ["cpsat", "greedy", "highs", "naive-pulp-cbc"]
    assert table.loc["greedy", "J"] == 3
    assert table.loc["greedy", "RMS"] == pytest.approx(0.6 / 10)
    assert table.loc["greedy", "worst shapes"] == "browUp_L (0.18)"
    records = records[~((records["kind"] == "transfer") & (records["j"] == 3))]
    assert worst_shapes_table(records).set_index("solver").loc["greedy", "worst shapes"] == (
        f"cheekPuff_L ({3 * 0.6 / 8:.3g}), cheekPuff_R ({2 * 0.6 / 8:.3g})"
    )
