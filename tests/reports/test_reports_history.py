"""The history of CI ratios: the file format, atomic appends that refuse foreign files, the spread rule of
`harness compare --history` on synthetic histories, and the history figure of `harness report`.

A synthetic history repeats the figures of a fabricated run under other dates and commits, each run's ratios
scaled by one factor: steady factors are a quiet machine, scattered ones a noisy one.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from reports import (
    BASELINE_SOLVER,
    HISTORY_COLUMNS,
    HistoryError,
    append_history,
    build_report,
    compare,
    read_history,
    run_figures,
)
from reports._figures import _history_lines, history_figure
from reports._history import LEGACY_COLUMNS, identify_legacy_rows, spreads
from reports.cli import compare as compare_command
from reports.cli import report as report_command

#: The committed baseline run and history of CI (`benchmarks/README.md`).
BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"

STEADY = [1.0, 1.02, 0.98, 1.01, 0.99, 1.03, 0.97, 1.0]
SCATTERED = [1.0, 1.3, 0.75, 1.25, 0.8, 1.35, 0.7, 1.0]
TIMES = {"naive-pulp-cbc": 2.0, "highs": 0.02, "cpsat": 0.03, "greedy": 0.001}


def _history(path, run, factors) -> pd.DataFrame:
    """Write a history of ``len(factors)`` runs with the figures of ``run`` times each factor."""
    template = run_figures(run)
    runs = [
        template.assign(
            date=f"2026-10-{i + 1:02d}T00:00:00+00:00", commit=f"{i:040x}", ratio=template["ratio"] * factor
        )
        for i, factor in enumerate(factors)
    ]
    append_history(path, pd.concat(runs))
    return read_history(path)


def _times(comparison, solver: str) -> dict[str, tuple[str, str]]:
    return {
        c.metric: (c.verdict, c.where)
        for c in comparison.changes
        if c.kind == "time" and c.case.endswith(solver)
    }


def _invoke(command, *args: object):
    result = CliRunner().invoke(command, [str(a) for a in args], catch_exceptions=False)
    print(result.output)
    return result


def test_a_run_gives_one_row_per_case_and_figure(make_run):
    figures = run_figures(make_run("run"))
    assert list(figures.columns) == list(HISTORY_COLUMNS)
    assert (
        len(figures) == 2 * 3
    )  # highs, cpsat, greedy: first expression and sequence (the reference has none)
    highs = figures[figures["case"].str.endswith("/highs")].set_index("figure")
    assert highs.loc["first expression / naive-pulp-cbc", "ratio"] == pytest.approx(0.01)
    assert highs.loc["first expression / naive-pulp-cbc", "seconds"] == pytest.approx(0.021)
    assert set(figures["machine"]) == {"test, 2 CPUs, ?, Python 3.11"}


def test_a_steady_history_flags_a_doubled_ratio(make_run, tmp_path):
    old = make_run("old")
    history = _history(tmp_path / "history.csv", old, STEADY)
    new = make_run("new", seconds=TIMES | {"highs": 0.04})
    comparison = compare(old, new, history=tmp_path / "history.csv")
    assert _times(comparison, "/highs") == {
        "first expression / naive-pulp-cbc": ("slower", "(history)"),
        "sequence / naive-pulp-cbc": ("slower", "(history)"),
    }
    assert set(_times(comparison, "/cpsat").values()) == {("same", "(history)")}
    assert set(_times(comparison, "/greedy").values()) == {("same", "(< 0.01 s)")}  # under the noise floor
    spread = next(c.spread for c in comparison.changes if c.case.endswith("/highs") and c.kind == "time")
    assert spread.runs == len(STEADY) and spread.median == pytest.approx(
        history["ratio"][history["case"].str.endswith("/highs")].iloc[0]
    )
    assert spread.high == pytest.approx(1.25 * spread.median)  # the minimum tolerance beats 3 MADs of 1 %
    assert comparison.regressions() == [] and len(comparison.warnings()) == 2


def test_noise_within_the_spread_is_not_flagged(make_run, tmp_path):
    old = make_run("old")
    _history(tmp_path / "history.csv", old, SCATTERED)
    new = make_run("new", seconds=TIMES | {"highs": 0.028})  # 1.4x the baseline's ratio
    assert set(_times(compare(old, new), "/highs").values()) == {("slower", "")}
    judged = compare(old, new, history=tmp_path / "history.csv")
    assert set(_times(judged, "/highs").values()) == {("same", "(history)")}
    assert set(
        _times(compare(old, new, history=tmp_path / "history.csv", spread=1.0), "/highs").values()
    ) == {("slower", "(history)")}


def test_a_slowdown_the_history_absorbed_is_not_flagged_again(make_run, tmp_path):
    old = make_run("old")
    slowed = make_run("slowed", seconds=TIMES | {"highs": 0.04})
    _history(tmp_path / "history.csv", slowed, STEADY)
    new = make_run("new", seconds=TIMES | {"highs": 0.04})
    assert set(_times(compare(old, new), "/highs").values()) == {("slower", "")}
    assert set(_times(compare(old, new, history=tmp_path / "history.csv"), "/highs").values()) == {
        ("same", "(history)")
    }


def test_a_short_history_falls_back_to_the_baseline_rule(make_run, tmp_path):
    old = make_run("old")
    _history(tmp_path / "history.csv", old, STEADY[:4])
    for highs in (0.04, 0.022):
        new = make_run(f"new-{highs}", seconds=TIMES | {"highs": highs})
        plain = compare(old, new)
        judged = compare(old, new, history=tmp_path / "history.csv")
        assert [(c.verdict, c.where, c.spread) for c in judged.changes] == [
            (c.verdict, c.where, None) for c in plain.changes
        ]
    assert set(_times(judged, "/highs").values()) == {("same", "")}
    assert compare(old, new, history=tmp_path / "history.csv", min_runs=4).changes != plain.changes


def test_a_case_of_another_grid_labelled_alike_is_not_its_history(make_run, tmp_path):
    """Runs that all keep importance on or all off label their cases alike (``face/alien/highs``): the
    history of one grid must not judge the other's ratios."""
    slowed = TIMES | {"highs": 0.04}
    other_grid = make_run("importance-off", importance=(False,), seconds=slowed)
    _history(tmp_path / "history.csv", other_grid, STEADY)
    old, new = make_run("old"), make_run("new", seconds=slowed)
    assert set(read_history(tmp_path / "history.csv")["case"]) == set(run_figures(new)["case"])
    judged = compare(old, new, history=tmp_path / "history.csv")
    # the other grid's history absorbed the slowdown; this grid's is judged by the one old run's rule
    assert set(_times(judged, "/highs").values()) == {("slower", "")}
    assert all(change.spread is None for change in judged.changes)


def test_rows_written_before_the_case_id_still_judge_by_their_label(make_run, tmp_path):
    old, path = make_run("old"), tmp_path / "history.csv"
    rows = _history(tmp_path / "current.csv", make_run("slowed", seconds=TIMES | {"highs": 0.04}), STEADY)
    legacy = rows[list(LEGACY_COLUMNS)].to_csv(index=False, float_format="%.6g", lineterminator="\n")
    path.write_text(legacy)
    assert set(read_history(path)["case_id"]) == {""}
    new = make_run("new", seconds=TIMES | {"highs": 0.04})
    assert set(_times(compare(old, new, history=path), "/highs").values()) == {("same", "(history)")}
    assert append_history(path, run_figures(new)) == 6
    earlier_rows = legacy.partition("\n")[2]
    assert path.read_text().startswith(",".join(HISTORY_COLUMNS) + "\n" + earlier_rows)
    history = read_history(path)
    assert list(history["case_id"] == "") == [True] * len(rows) + [False] * 6
    assert (
        compare(old, new, history=path).changes == compare(old, new, history=tmp_path / "current.csv").changes
    )


def test_the_committed_history_still_judges_the_baseline_cases():
    history = read_history(BENCHMARKS / "history.csv")
    figures = run_figures(BENCHMARKS / "baseline")
    identified = identify_legacy_rows(history, dict(zip(figures["case"], figures["case_id"], strict=True)))
    judged = spreads(identified)
    assert judged and set(judged) <= set(zip(figures["case_id"], figures["figure"], strict=True))
    assert all(figure.endswith(f"/ {BASELINE_SOLVER}") for _, figure in judged)


def test_the_judged_run_is_left_out_of_its_own_history(make_run, tmp_path):
    old = make_run("old")
    path = tmp_path / "history.csv"
    _history(path, old, STEADY)
    new = make_run("new", seconds=TIMES | {"highs": 0.04})
    before = compare(old, new, history=path)
    assert append_history(path, run_figures(new)) == 6
    assert compare(old, new, history=path).changes == before.changes


def test_appending_keeps_earlier_bytes_and_adds_a_run_once(make_run, tmp_path):
    path = tmp_path / "history.csv"
    first = make_run("first")
    assert append_history(path, run_figures(first)) == 6
    text = path.read_text()
    assert text.splitlines()[0] == ",".join(HISTORY_COLUMNS)
    assert append_history(path, run_figures(first)) == 0
    assert path.read_text() == text
    later = run_figures(first).assign(date="2026-11-23T00:00:00+00:00")
    assert append_history(path, later) == 6
    assert path.read_text().startswith(text) and len(read_history(path)) == 12
    assert sorted(p.name for p in tmp_path.iterdir() if p.is_file()) == ["history.csv"]  # no temporary left


@pytest.mark.parametrize(
    "content",
    ["date,commit\n2026,abc\n", "not,a,history\n", ",".join(HISTORY_COLUMNS) + "\nx,y,maybe,m,c,f,1,2\n"],
    ids=["other-columns", "other-csv", "bad-row"],
)
def test_a_file_of_another_kind_is_refused_and_left_alone(make_run, tmp_path, content):
    path = tmp_path / "history.csv"
    path.write_text(content)
    with pytest.raises(HistoryError, match="not a history file"):
        append_history(path, run_figures(make_run("run")))
    assert path.read_text() == content
    result = _invoke(compare_command, make_run("old"), make_run("new"), "--history", path, "--append")
    assert result.exit_code == 2
    assert "not a history file" in result.output and len(result.output.strip().splitlines()) == 1
    assert path.read_text() == content


def test_the_compare_command_judges_then_appends(make_run, tmp_path):
    old, path = make_run("old"), tmp_path / "history.csv"
    _history(path, old, STEADY)
    new = make_run("new", seconds=TIMES | {"highs": 0.04})
    result = _invoke(compare_command, old, new, "--history", path, "--append", "--only-changes")
    assert result.exit_code == 0
    assert "2 timing warnings (4 times judged by the history)" in result.output
    assert f"appended 6 figures of {new}" in result.output
    assert "median" in result.output and "over 8 runs" in result.output
    result = _invoke(compare_command, old, new, "--history", path, "--append")
    assert result.exit_code == 0 and "is already in" in result.output
    assert len(read_history(path)) == 9 * 6


def test_the_compare_command_creates_a_history_and_checks_its_options(make_run, tmp_path):
    old, new, path = make_run("old"), make_run("new"), tmp_path / "history.csv"
    result = _invoke(compare_command, old, new, "--history", path)
    assert result.exit_code == 2 and "no such history file" in result.output
    assert _invoke(compare_command, old, new, "--append").exit_code == 2
    result = _invoke(compare_command, old, new, "--history", path, "--append")
    assert result.exit_code == 0 and path.is_file() and len(read_history(path)) == 6


def test_a_history_applies_to_run_directories_only(make_run, tmp_path):
    path = tmp_path / "history.csv"
    _history(path, make_run("run"), STEADY)
    (tmp_path / "bench.json").write_text('{"benchmarks": []}')
    with pytest.raises(ValueError, match="a history applies to run directories"):
        compare(tmp_path / "bench.json", tmp_path / "bench.json", history=path)
    with pytest.raises(ValueError, match="window and min_runs >= 1"):
        compare(tmp_path / "run", tmp_path / "run", history=path, window=0)


def test_the_report_plots_the_history(make_run, tmp_path):
    run = make_run("run")
    _history(tmp_path / "history.csv", run, STEADY)
    result = _invoke(report_command, run)  # finds history.csv beside the run
    assert result.exit_code == 0
    figure = run / "report" / "figures" / "history.png"
    assert figure.read_bytes().startswith(b"\x89PNG")
    markdown = (run / "report" / "report.md").read_text()
    assert "## Performance history" in markdown and "(figures/history.png)" in markdown
    assert "Times of the 8 runs recorded in" in markdown
    page = (run / "report" / "index.html").read_text()
    assert "<h2>Performance history</h2>" in page and page.count("data:image/png;base64,") >= 1


def test_a_report_without_a_history_has_no_history_section(make_run, tmp_path):
    page, text = build_report(make_run("run"))
    assert "Performance history" not in text.read_text()
    assert not (page.parent / "figures" / "history.png").exists()


def test_a_run_with_regressions_is_not_appended_to_the_history(make_run, fabric, tmp_path):
    old, path = make_run("old"), tmp_path / "history.csv"
    _history(path, old, STEADY)
    before = path.read_bytes()
    worse = [fabric["optimal"][0], ["smile_L", "smile_R"], fabric["optimal"][2]]
    sequences = {"naive-pulp-cbc": fabric["optimal"], "highs": worse, "cpsat": fabric["optimal"]}
    new = make_run("new", sequences=sequences | {"greedy": fabric["greedy"]})
    result = _invoke(compare_command, old, new, "--history", path, "--append")
    assert result.exit_code == 1 and "regressions" in result.output
    assert path.read_bytes() == before


def test_the_history_figure_draws_cases_labelled_alike_apart_and_old_rows_with_their_case(make_run, tmp_path):
    rows = pd.DataFrame(
        {
            "case": ["face/highs", "face/highs", "face/highs", "face/cpsat"],
            "case_id": ["rig=face; importance=True", "rig=face; importance=False", "", ""],
        }
    )
    lines = _history_lines(rows)
    assert list(lines) == [
        "face/highs",
        "face/highs [2]",
        "face/highs [3]",
        "face/cpsat",
    ]  # (ambiguous: apart)
    rows.loc[1, "case"] = "face/cpsat"  # one known case per label: the old rows join it
    assert list(_history_lines(rows)) == ["face/highs", "face/cpsat", "face/highs", "face/cpsat"]
    on, off = make_run("importance-on"), make_run("importance-off", importance=(False,))
    history = pd.concat(
        [_history(tmp_path / "on.csv", on, STEADY[:2]), _history(tmp_path / "off.csv", off, STEADY)]
    )
    labels = [text.get_text() for text in history_figure(history).legends[0].get_texts()]
    cases = set(run_figures(on)["case"])
    assert set(run_figures(off)["case"]) == cases  # the two grids label their cases alike
    assert len(labels) == len(set(labels)) == 2 * len(cases)
