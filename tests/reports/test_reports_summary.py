"""Solver benchmark summaries across instances: shifted geometric means, outcome counts, wins, Dolan-More
performance profiles, and their section of the report of a real run."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from harness.cli import cli
from reports import (
    build_report,
    common_table,
    common_times,
    distribution_figure,
    outcome_table,
    performance_profile,
    performance_ratios,
    profile_figure,
    sequence_table,
    shifted_geometric_mean,
    solve_outcomes,
    wins,
)

SGM = "build + solve sgm (ms)"


def _solve(group, solver: str, seconds: float, *, expression: int = 1, repetition: int = 0, **fields) -> dict:
    """An expression row of solver's cell in repetition ``repetition``, ``seconds`` of it solving."""
    return {
        **group("face", repetition=repetition),
        "kind": "expression",
        "cell": f"{solver}-{repetition}",
        "solver": solver,
        "expression": expression,
        "shapes": fields.pop("shapes", [f"shape{expression}"]),
        "termination": "optimal",
        "status": "optimal",
        "build_time": 0.0,
        "solve_time": seconds,
        "sequence_time": np.nan,
        **fields,
    }


def _cell(group, solver: str, status: str, *, repetition: int = 0, seconds: float = np.nan, **fields) -> dict:
    """The cell row of solver's cell in repetition ``repetition``."""
    return {
        **group("face", repetition=repetition),
        "kind": "cell",
        "cell": f"{solver}-{repetition}",
        "solver": solver,
        "expression": np.nan,
        "shapes": None,
        "termination": None,
        "status": status,
        "build_time": np.nan,
        "solve_time": np.nan,
        "sequence_time": seconds,
        **fields,
    }


def _row(table: pd.DataFrame, solver: str, compared: str | None = None) -> pd.Series:
    rows = table[table["solver"] == solver]
    if compared is not None:
        rows = rows[rows["compared"] == compared]
    (index,) = rows.index
    return rows.loc[index]


def test_shifted_geometric_mean_matches_a_hand_computed_value():
    times = [0.001, 0.003, 0.009]
    expected = (0.002 * 0.004 * 0.010) ** (1 / 3) - 0.001  # 3.3089 ms
    assert shifted_geometric_mean(times, shift=0.001) == pytest.approx(expected, rel=1e-12)
    assert shifted_geometric_mean(times, shift=0.001) == pytest.approx(3.3089e-3, rel=1e-4)
    assert shifted_geometric_mean(times, shift=0.0) == pytest.approx(0.003, rel=1e-12)
    assert shifted_geometric_mean([0.0, 0.0], shift=0.001) == pytest.approx(0.0, abs=1e-15)


def test_outcome_table_means_each_solvers_times_and_counts_its_outcomes(group):
    records = pd.DataFrame(
        [
            _solve(group, "a", 0.001, expression=1),
            _solve(group, "a", 0.003, expression=2, build_time=0.0005),
            _solve(group, "a", 0.009, expression=3, termination="completed"),
            _solve(group, "b", 0.002),
        ]
    )
    table = outcome_table(solve_outcomes(records))
    a = _row(table, "a")
    assert (a["solves"], a["optimal"], a["completed"], a["time limit"]) == (3, 2, 1, 0)
    assert a["solve sgm (ms)"] == pytest.approx(1e3 * ((0.002 * 0.004 * 0.010) ** (1 / 3) - 0.001))
    assert a[SGM] == pytest.approx(1e3 * ((0.002 * 0.0045 * 0.010) ** (1 / 3) - 0.001))
    assert _row(table, "b")[SGM] == pytest.approx(2.0)


def test_a_fast_time_limited_solve_is_charged_at_the_limit_and_ranks_below_a_slow_optimal_one(group):
    rows = []
    for repetition in range(3):
        rows.append(
            _solve(group, "fast", 0.001, repetition=repetition, termination="time_limit", time_limit=10.0)
        )
        rows.append(_solve(group, "slow", 1.0, repetition=repetition, time_limit=10.0))
    solves = solve_outcomes(pd.DataFrame(rows))
    assert solves.loc[solves["solver"] == "fast", "charged"].tolist() == [10.0] * 3
    table = outcome_table(solves)
    assert _row(table, "fast")["time limit"] == 3
    assert _row(table, "fast")[SGM] > _row(table, "slow")[SGM]
    assert _row(table, "fast")[SGM] == pytest.approx(1e4, rel=1e-6)
    common = common_table(solves)
    assert (_row(common, "fast")["solved"], _row(common, "fast")["wins"]) == (0, 0)
    assert (_row(common, "slow")["solved"], _row(common, "slow")["wins"]) == (3, 3)


def test_a_time_limited_solve_that_overran_its_limit_is_charged_what_it_took(group):
    """A 1 ms limit that the backend overshot by 60 ms must not make it the fastest solver in the table."""
    rows = [
        _solve(group, "overran", 0.06, termination="time_limit", time_limit=0.001),
        _solve(group, "solved", 0.01, time_limit=0.001, termination="optimal"),
    ]
    solves = solve_outcomes(pd.DataFrame(rows))
    assert solves.loc[solves["solver"] == "overran", "charged_solve"].tolist() == [0.06]
    table = outcome_table(solves)
    assert _row(table, "overran")[SGM] > _row(table, "solved")[SGM]


def test_without_a_recorded_limit_the_given_one_is_charged_and_an_errored_cell_fails_expression_1(group):
    records = pd.DataFrame(
        [
            _solve(group, "a", 0.5, termination="error"),
            _cell(group, "b", "error", message="boom"),
            _cell(group, "c", "skipped"),
            _solve(group, "d", 0.1),
        ]
    )
    solves = solve_outcomes(records, time_limit=30.0)
    charged = solves.set_index("solver")["charged"]
    assert charged.to_dict() == {"a": 30.0, "b": 30.0, "d": pytest.approx(0.1)}  # skipped c ran nothing
    assert solves.set_index("solver")["outcome"].to_dict() == {"a": "error", "b": "error", "d": "optimal"}
    assert solve_outcomes(records)["limit"].tolist() == [0.5, 0.5, 0.5]  # no limit at all: the longest solve


def test_wins_and_counts_on_common_instances(group):
    # Three exact solvers and a heuristic on two repetitions; x and y tie (within 1%) in repetition 0,
    # z errors in repetition 1, and the heuristic is fastest wherever it runs.
    rows = [
        _solve(group, "x", 0.0100, repetition=0),
        _solve(group, "y", 0.0100 * 1.005, repetition=0),
        _solve(group, "z", 0.0200, repetition=0),
        _solve(group, "h", 0.0001, repetition=0, termination="completed"),
        _solve(group, "x", 0.0300, repetition=1),
        _solve(group, "y", 0.0200, repetition=1),
        _cell(group, "z", "timeout", repetition=1),
        _solve(group, "h", 0.0001, repetition=1, termination="completed"),
    ]
    solves = solve_outcomes(pd.DataFrame(rows), time_limit=5.0)
    table = common_table(solves)
    exact = table[table["compared"] == "exact solvers"].set_index("solver")
    assert exact["instances"].tolist() == [2, 2, 2]
    assert exact["wins"].to_dict() == {"x": 1, "y": 2, "z": 0}
    assert exact["solved"].to_dict() == {"x": 2, "y": 2, "z": 1}
    assert exact["not solved"].to_dict() == {"x": 0, "y": 0, "z": 1}
    every = table[table["compared"] == "every solver"].set_index("solver")
    assert every["wins"].to_dict() == {"h": 2, "x": 0, "y": 0, "z": 0}
    counts = outcome_table(solves).set_index("solver")
    assert counts.loc["z", ["optimal", "timeout", "error"]].tolist() == [1, 1, 0]


def test_later_expressions_are_common_only_after_identical_earlier_choices(group):
    rows = [
        _solve(group, "x", 0.01, expression=1, shapes=["a", "b"]),
        _solve(group, "x", 0.01, expression=2, shapes=["c"]),
        _solve(group, "y", 0.02, expression=1, shapes=["b", "a"]),
        _solve(group, "y", 0.02, expression=2, shapes=["c"]),
        _solve(group, "g", 0.01, expression=1, shapes=["a"], termination="completed"),
        _solve(group, "g", 0.01, expression=2, shapes=["b", "c"], termination="completed"),
    ]
    solves = solve_outcomes(pd.DataFrame(rows))
    assert len(common_times(solves, ["x", "y"], {"optimal"})) == 2  # same shapes, in any order
    assert len(common_times(solves, ["x", "y", "g"], {"optimal", "completed"})) == 1  # g chose differently


def test_performance_profile_of_two_solvers_on_three_instances(group):
    # a: 1 s, 2 s, time limit; b: 2 s, 1 s, 4 s -> ratios a: 1, 2, inf; b: 2, 1, 1.
    rows = []
    for repetition, (a, b) in enumerate([(1.0, 2.0), (2.0, 1.0), (0.5, 4.0)]):
        limited = {"termination": "time_limit"} if repetition == 2 else {}
        rows += [
            _solve(group, "a", a, repetition=repetition, time_limit=10.0, **limited),
            _solve(group, "b", b, repetition=repetition, time_limit=10.0),
        ]
    solves = solve_outcomes(pd.DataFrame(rows))
    ratios = performance_ratios(common_times(solves, ["a", "b"], {"optimal"}))
    assert ratios["a"].tolist() == [1.0, 2.0, np.inf]
    assert ratios["b"].tolist() == [2.0, 1.0, 1.0]
    profile = performance_profile(ratios)
    assert profile.index.tolist() == [1.0, 2.0]
    assert profile["a"].tolist() == [1 / 3, 2 / 3]
    assert profile["b"].tolist() == [2 / 3, 1.0]
    far = performance_profile(ratios, taus=[1.5, 1e9])
    assert far["a"].tolist() == [1 / 3, 2 / 3]  # the time-limited instance is never solved
    assert wins(ratios).to_dict() == {"a": 1, "b": 2}

    figure = profile_figure(solves)
    (ax,) = figure.axes
    assert ax.get_xscale() == "log"
    lines = {line.get_label(): line for line in ax.get_lines()}
    assert list(lines["a"].get_ydata())[:2] == [1 / 3, 2 / 3]
    labels = [tick.get_text() for tick in distribution_figure(solves).axes[0].get_xticklabels()]
    assert labels == ["a\n(n=3)", "b\n(n=3)"]


def test_sequence_table_charges_a_failed_cell_at_the_timeout(group):
    records = pd.DataFrame(
        [
            _cell(group, "x", "ok", repetition=0, seconds=0.004),
            _cell(group, "x", "invalid", repetition=1),
            _cell(group, "y", "ok", repetition=0, seconds=0.1),
            _cell(group, "y", "skipped", repetition=1),
        ]
    )
    table = sequence_table(records, timeout=1.0, shift=0.001).set_index("solver")
    assert table.loc["x", ["cells ok", "cells failed"]].tolist() == [1, 1]
    assert table.loc["x", "sequence sgm (ms)"] == pytest.approx(1e3 * ((0.005 * 1.001) ** 0.5 - 0.001))
    assert table.loc["y", ["cells ok", "cells failed"]].tolist() == [1, 0]


@pytest.fixture(scope="module")
def real_run(tmp_path_factory, face_rig_file) -> Path:
    """A real `harness run` of two exact solvers and greedy on the face rig, two repetitions, reported."""
    out = tmp_path_factory.mktemp("summary") / "run"
    arguments = [
        "run", "--rigs", str(face_rig_file), "--warps", "none", "--solvers", "highs,cpsat,greedy",
        "--transfers", "delta", "--j-values", "1", "--repetitions", "2", "--jobs", "1", "--quiet",
        "--out", str(out),
    ]  # fmt: skip
    result = CliRunner().invoke(cli, arguments, catch_exceptions=False)
    assert result.exit_code == 0, result.output
    build_report(out)
    return out


def test_the_report_of_a_real_run_has_the_summary_tables_and_figures(real_run):
    markdown = (real_run / "report" / "report.md").read_text()
    section = markdown.split("## Solvers across instances", 1)[1].split("\n## ", 1)[0]
    assert "shift 1 ms" in section
    assert "| solver | solves | optimal | completed | time limit |" in section
    assert "| exact solvers | cpsat |" in section and "| every solver | greedy |" in section
    assert "| solver | cells ok | cells failed | sequence sgm (ms) |" in section
    for name in ("performance-profile", "solve-times"):
        assert f"(figures/{name}.png)" in section
        assert (real_run / "report" / "figures" / f"{name}.png").stat().st_size > 1000
    assert "Solvers across instances" in (real_run / "report" / "index.html").read_text()
