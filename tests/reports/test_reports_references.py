"""Transfer errors against the references (dt, delta) and the separation of packings, from fabricated runs."""

from __future__ import annotations

import pytest

import harness
from reports import REFERENCE_TRANSFERS, rms_table, separation_table

OPTIMAL_GROUP = "cpsat = highs = naive-pulp-cbc"


@pytest.fixture
def records(make_run):
    return harness.read_records(make_run("run", importance=(True, False), transfers=("ebfr", "dt", "delta")))


def test_the_absolute_table_merges_identical_solvers_and_lists_each_reference_once(records):
    table = rms_table(records)
    assert list(table.columns) == ["rig", "warp", "setting", "transfer", "solvers", "J=1", "J=2", "J=3"]
    ebfr = table[(table["transfer"] == "ebfr") & (table["setting"] == "importance off")].set_index("solvers")
    assert list(ebfr.index) == [OPTIMAL_GROUP, "greedy"]
    assert ebfr.loc["greedy", ["J=1", "J=2", "J=3"]].tolist() == pytest.approx(
        [0.66 / 3, 0.66 / 8, 0.66 / 10]
    )
    references = table[table["transfer"].isin(REFERENCE_TRANSFERS)]
    assert set(references["solvers"]) == {"every solver"}
    assert sorted(references["transfer"]) == ["delta", "delta", "dt", "dt"]  # once per setting
    assert references[references["transfer"] == "dt"]["J=2"].tolist() == [0.25, 0.25]


@pytest.mark.parametrize(("reference", "value"), [("dt", 0.25), ("delta", 0.3)])
def test_relative_tables_divide_by_the_reference_of_the_same_cell_and_j(records, reference, value):
    table = rms_table(records, reference)
    assert set(table["transfer"]) == {"ebfr"}
    greedy = table[(table["solvers"] == "greedy") & (table["setting"] == "importance on")].iloc[0]
    assert [greedy["J=1"], greedy["J=2"], greedy["J=3"]] == pytest.approx(
        [0.6 / 3 / value, 0.6 / 8 / value, 0.6 / 10 / value]
    )


def test_covered_and_uncovered_parts_are_divided_by_the_reference_over_all_shapes(records):
    covered = rms_table(records, "dt", "rms_covered")
    uncovered = rms_table(records, "dt", "rms_uncovered")
    row = lambda table: table[(table["solvers"] == "greedy") & (table["setting"] == "importance on")].iloc[0]  # noqa: E731
    assert row(covered)["J=1"] == pytest.approx(0.5 * 0.6 / 3 / 0.25)
    assert row(uncovered)["J=1"] == pytest.approx(2 * 0.6 / 3 / 0.25)


def test_without_a_reference_the_relative_table_is_empty(make_run):
    records = harness.read_records(make_run("run", transfers=("ebfr",)))
    assert rms_table(records, "dt").empty
    assert set(rms_table(records)["transfer"]) == {"ebfr"}


def test_separation_compares_the_spread_of_packings_with_the_noise_over_repetitions(make_run):
    records = harness.read_records(make_run("run", transfers=("ebfr", "dt"), noise=0.02))
    table = separation_table(records).set_index("J")
    assert list(table.index) == [1, 2, 3] and set(table["transfer"]) == {"ebfr"}
    # J=1: greedy covers 2 shapes (0.6/3), the optimal solvers 3 (0.6/4); each wobbles by +-1%.
    row = table.loc[1]
    assert row["packings"] == 2
    assert row["best"] == OPTIMAL_GROUP and row["worst"] == "greedy"
    assert row["spread"] == pytest.approx(0.6 / 3 - 0.6 / 4)
    deviations = [0.02 * value / 2**0.5 for value in (0.6 / 3, 0.6 / 4)]  # two repetitions, +-1%
    assert row["noise"] == pytest.approx((sum(d**2 for d in deviations) / 2) ** 0.5)
    assert row["spread / noise"] == pytest.approx(row["spread"] / row["noise"])


def test_one_repetition_gives_no_noise_estimate(make_run):
    records = harness.read_records(make_run("run", repetitions=1, transfers=("ebfr",)))
    table = separation_table(records)
    assert table["noise"].isna().all() and table["spread / noise"].isna().all()
    assert (table["spread"] >= 0).all()


def test_separation_names_settings_when_they_vary(records):
    row = separation_table(records).set_index("J").loc[1]
    assert row["packings"] == 4
    assert row["best"] == f"{OPTIMAL_GROUP} (importance on)" and row["worst"] == "greedy (importance off)"
