"""The history of CI ratios: the file format, atomic appends that refuse foreign files, the spread rule of
`harness compare --history` over commits on synthetic histories, and the history figure of `harness report`.

A synthetic history repeats the figures of a fabricated run under other dates and commits, each run's ratios
scaled by one factor: steady factors are a quiet machine, scattered ones a noisy one. The fabricated runs
have two repetitions, too few for the test, so the history judges them.
"""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from reports import (
    HISTORY_COLUMNS,
    HistoryError,
    append_history,
    build_report,
    compare,
    read_history,
    run_figures,
)
from reports._figures import _history_lines, history_figure
from reports._history import spreads
from reports._timing import REFERENCE
from reports.cli import compare as compare_command
from reports.cli import report as report_command

#: The committed baseline run and history of CI (`benchmarks/README.md`).
BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"

SEQUENCE = f"sequence / {REFERENCE}"
STEADY = [1.0, 1.02, 0.98, 1.01, 0.99, 1.03, 0.97, 1.0]
SCATTERED = [1.0, 1.3, 0.75, 1.25, 0.8, 1.35, 0.7, 1.0]
TIMES = {"naive-pulp-cbc": 2.0, "highs": 0.02, "cpsat": 0.03, "greedy": 0.001}
#: naive-pulp-cbc twice as slow: it stays the slowest exact solver, so the reference of the others holds
SLOWED = TIMES | {"naive-pulp-cbc": 4.0}


def _history(path, run, factors, *, commit: str | None = None) -> pd.DataFrame:
    """Write a history of ``len(factors)`` runs with the figures of ``run`` times each factor, each run at
    a commit of its own, or all at ``commit``."""
    template = run_figures(run)
    runs = [
        template.assign(
            date=f"2026-10-{i + 1:02d}T00:00:00+00:00",
            commit=commit or f"{i:040x}",
            ratio=template["ratio"] * factor,
        )
        for i, factor in enumerate(factors)
    ]
    append_history(path, pd.concat(runs))
    return read_history(path)


def _at_commit(run: Path, commit: str, started: str) -> Path:
    """``run`` as if made from a clean tree at ``commit``, started at ``started``."""
    document = json.loads((run / "run.json").read_text())
    document |= {"git": {"commit": commit, "dirty": False}, "started": started}
    (run / "run.json").write_text(json.dumps(document))
    return run


def _time(comparison, solver: str) -> tuple[str, str]:
    """Verdict and how it was reached, of the one time of ``solver``'s case."""
    (change,) = [c for c in comparison.changes if c.kind == "time" and c.case.endswith(f"/{solver}")]
    return change.verdict, "(untested)" if change.where.startswith("(untested") else change.where


def _invoke(command, *args: object):
    result = CliRunner().invoke(command, [str(a) for a in args], catch_exceptions=False)
    print(result.output)
    return result


def test_a_run_gives_one_row_per_case_and_figure(make_run):
    figures = run_figures(make_run("run"))
    assert list(figures.columns) == list(HISTORY_COLUMNS)
    assert len(figures) == 4 and set(figures["figure"]) == {SEQUENCE}  # one per solver
    highs = figures[figures["case"].str.endswith("/highs")].iloc[0]
    # the reference is the log-median of the four exact solvers: sqrt(highs x cpsat) in every repetition
    assert highs["ratio"] == pytest.approx((0.02 / 0.03) ** 0.5)
    assert highs["seconds"] == pytest.approx(0.063)  # median of 3 x 0.02 and 3 x 0.022
    assert set(figures["machine"]) == {"test, 2 CPUs, ?, Python 3.11"}


def test_a_steady_history_flags_a_doubled_ratio(make_run, tmp_path):
    old = make_run("old")
    history = _history(tmp_path / "history.csv", old, STEADY)
    new = make_run("new", seconds=SLOWED)
    comparison = compare(old, new, history=tmp_path / "history.csv")
    assert _time(comparison, "naive-pulp-cbc") == ("slower", "(history)")
    assert _time(comparison, "highs") == _time(comparison, "cpsat") == ("same", "(history)")
    assert _time(comparison, "greedy") == ("same", "(< 0.01 s)")  # under the noise floor
    assert _time(compare(old, new), "naive-pulp-cbc") == ("same", "(untested)")  # without the history
    spread = next(c.spread for c in comparison.changes if c.case.endswith("/naive-pulp-cbc") and c.spread)
    cbc = history["ratio"][history["case"].str.endswith("/naive-pulp-cbc")]
    assert spread.commits == len(STEADY) and spread.median == pytest.approx(cbc.iloc[0])
    assert spread.high == pytest.approx(1.25 * spread.median)  # the minimum tolerance beats 3 MADs of 1 %
    assert comparison.regressions() == [] and len(comparison.warnings()) == 1


def test_noise_within_the_spread_is_not_flagged(make_run, tmp_path):
    old = make_run("old")
    _history(tmp_path / "history.csv", old, SCATTERED)
    new = make_run("new", seconds=TIMES | {"naive-pulp-cbc": 2.8})  # 1.4x the baseline's ratio
    judged = compare(old, new, history=tmp_path / "history.csv")
    assert _time(judged, "naive-pulp-cbc") == ("same", "(history)")
    narrow = compare(old, new, history=tmp_path / "history.csv", spread=1.0)
    assert _time(narrow, "naive-pulp-cbc") == ("slower", "(history)")


def test_a_slowdown_the_history_absorbed_is_not_flagged_again(make_run, tmp_path):
    old = make_run("old")
    _history(tmp_path / "history.csv", make_run("slowed", seconds=SLOWED), STEADY)
    new = make_run("new", seconds=SLOWED)
    assert _time(compare(old, new, history=tmp_path / "history.csv"), "naive-pulp-cbc") == (
        "same",
        "(history)",
    )


def test_a_short_history_leaves_the_times_untested(make_run, tmp_path):
    old = make_run("old")
    _history(tmp_path / "history.csv", old, STEADY[:4])
    new = make_run("new", seconds=SLOWED)
    plain = compare(old, new)
    judged = compare(old, new, history=tmp_path / "history.csv")
    assert [(c.verdict, c.where, c.spread) for c in judged.changes] == [
        (c.verdict, c.where, None) for c in plain.changes
    ]
    assert _time(judged, "naive-pulp-cbc") == ("same", "(untested)")
    four = compare(old, new, history=tmp_path / "history.csv", min_runs=4)
    assert _time(four, "naive-pulp-cbc") == ("slower", "(history)")


def test_runs_of_one_commit_count_as_one_commit(make_run, tmp_path):
    """Back-to-back runs of one commit agree closely, yet say nothing about how a figure moves from commit
    to commit: however many there are, they are one value of the history and make no spread."""
    old = make_run("old")
    history = _history(tmp_path / "history.csv", old, STEADY, commit="c" * 40)
    new = make_run("new", seconds=SLOWED)
    judged = compare(old, new, history=tmp_path / "history.csv")
    assert _time(judged, "naive-pulp-cbc") == ("same", "(untested)")
    assert all(change.spread is None for change in judged.changes)
    one = compare(old, new, history=tmp_path / "history.csv", min_runs=1)  # one commit suffices here
    assert _time(one, "naive-pulp-cbc") == ("slower", "(history)")
    assert spreads(history, min_runs=2) == {}
    alone = spreads(history, min_runs=1)
    cbc = history[history["case"].str.endswith("/naive-pulp-cbc")]
    spread = alone[(cbc["case_id"].iloc[0], SEQUENCE)]
    assert spread.commits == 1 and spread.median == pytest.approx(cbc["ratio"].median())


def test_the_spread_takes_each_commits_median_over_the_last_commits():
    def row(date: int, commit: str, ratio: float, dirty: bool = False) -> dict:
        return {
            "date": f"2026-10-{date:02d}T00:00:00+00:00",
            "commit": commit,
            "dirty": dirty,
            "machine": "m",
            "case": "face/alien/highs",
            "figure": SEQUENCE,
            "ratio": ratio,
            "seconds": 0.1,
            "case_id": "rig=face; solver=highs",
        }

    rows = [  # per commit, three back-to-back runs, one of them disturbed: the median of each is 1.0
        row(3 * i + j + 1, f"{i:040x}", 1.0 + 0.01 * i if j != 1 else 5.0) for i in range(6) for j in range(3)
    ]
    rows += [row(25, "f" * 40, 9.0, dirty=True), row(26, "", 9.0)]  # a dirty tree, no git: no commit
    (spread,) = spreads(pd.DataFrame(rows), window=4, min_runs=4).values()
    assert spread.commits == 4  # the last four commits, not the last four runs
    assert spread.median == pytest.approx(1.035)  # the medians 1.02 ... 1.05 of commits 2 to 5
    assert spreads(pd.DataFrame(rows), min_runs=7) == {}  # six commits, eighteen runs


def test_a_case_of_another_grid_labelled_alike_is_not_its_history(make_run, tmp_path):
    """Runs that all keep importance on or all off label their cases alike (``face/alien/highs``): the
    history of one grid must not judge the other's ratios."""
    other_grid = make_run("importance-off", importance=(False,))
    _history(tmp_path / "history.csv", other_grid, STEADY)
    old, new = make_run("old"), make_run("new", seconds=SLOWED)
    assert set(read_history(tmp_path / "history.csv")["case"]) == set(run_figures(new)["case"])
    judged = compare(old, new, history=tmp_path / "history.csv")
    # the other grid's steady history would call the doubled ratio slower; this grid has none
    assert _time(judged, "naive-pulp-cbc") == ("same", "(untested)")
    assert all(change.spread is None for change in judged.changes)


def test_the_committed_history_reads_and_the_baseline_gives_its_figures(tmp_path):
    history = read_history(BENCHMARKS / "history.csv")
    assert history.empty and list(history.columns) == list(HISTORY_COLUMNS)
    figures = run_figures(BENCHMARKS / "baseline")
    assert len(figures) and set(figures["figure"]) == {SEQUENCE}
    assert figures["case_id"].is_unique and (figures["ratio"] > 0).all()
    assert (figures["commit"] != "").all() and not figures["dirty"].any()  # a committed, clean run
    copy = tmp_path / "history.csv"
    copy.write_bytes((BENCHMARKS / "history.csv").read_bytes())
    assert append_history(copy, figures) == len(figures)
    judged = spreads(read_history(copy), min_runs=1)
    assert set(judged) == set(zip(figures["case_id"], figures["figure"], strict=True))


def test_the_judged_run_is_left_out_of_its_own_history(make_run, tmp_path):
    old = make_run("old")
    path = tmp_path / "history.csv"
    _history(path, old, STEADY[:4])  # one commit short of a spread
    new = _at_commit(make_run("new", seconds=SLOWED), "e" * 40, "2026-11-23T00:00:00+00:00")
    before = compare(old, new, history=path)
    assert append_history(path, run_figures(new)) == 4
    assert spreads(read_history(path))  # with the judged run, five commits
    after = compare(old, new, history=path)
    assert after.changes == before.changes and all(change.spread is None for change in after.changes)


def test_appending_keeps_earlier_bytes_and_adds_a_run_once(make_run, tmp_path):
    path = tmp_path / "history.csv"
    first = make_run("first")
    assert append_history(path, run_figures(first)) == 4
    text = path.read_text()
    assert text.splitlines()[0] == ",".join(HISTORY_COLUMNS)
    assert append_history(path, run_figures(first)) == 0
    assert path.read_text() == text
    later = run_figures(first).assign(date="2026-11-23T00:00:00+00:00")
    assert append_history(path, later) == 4
    assert path.read_text().startswith(text) and len(read_history(path)) == 8
    assert sorted(p.name for p in tmp_path.iterdir() if p.is_file()) == ["history.csv"]  # no temporary left


@pytest.mark.parametrize(
    "content",
    [
        "date,commit\n2026,abc\n",
        "not,a,history\n",
        ",".join(HISTORY_COLUMNS) + "\nx,y,maybe,m,c,f,1,2,i\n",
        ",".join(HISTORY_COLUMNS) + "\nx,y,False,m,c,f,1,2,\n",
        ",".join(HISTORY_COLUMNS[:-1]) + "\nx,y,False,m,c,f,1,2\n",
    ],
    ids=["other-columns", "other-csv", "bad-row", "no-case-id", "without-the-case-id-column"],
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
    new = make_run("new", seconds=SLOWED)
    result = _invoke(compare_command, old, new, "--history", path, "--append", "--only-changes")
    assert result.exit_code == 0
    assert "1 timing warnings (3 times judged by the history)" in result.output  # greedy: noise floor
    assert f"appended 4 figures of {new}" in result.output
    assert "median" in result.output and "over 8 commits" in result.output
    result = _invoke(compare_command, old, new, "--history", path, "--append")
    assert result.exit_code == 0 and "is already in" in result.output
    assert len(read_history(path)) == 9 * 4


def test_the_compare_command_creates_a_history_and_checks_its_options(make_run, tmp_path):
    old, new, path = make_run("old"), make_run("new"), tmp_path / "history.csv"
    result = _invoke(compare_command, old, new, "--history", path)
    assert result.exit_code == 2 and "no such history file" in result.output
    assert _invoke(compare_command, old, new, "--append").exit_code == 2
    result = _invoke(compare_command, old, new, "--history", path, "--append")
    assert result.exit_code == 0 and path.is_file() and len(read_history(path)) == 4


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


def test_the_history_figure_draws_cases_labelled_alike_apart(make_run, tmp_path):
    rows = pd.DataFrame(
        {
            "case": ["face/highs", "face/highs", "face/highs", "face/cpsat"],
            "case_id": [
                "rig=face; importance=True",
                "rig=face; importance=False",
                "rig=face; importance=True",
                "x",
            ],
        }
    )
    assert list(_history_lines(rows)) == ["face/highs", "face/highs [2]", "face/highs", "face/cpsat"]
    on, off = make_run("importance-on"), make_run("importance-off", importance=(False,))
    history = pd.concat(
        [_history(tmp_path / "on.csv", on, STEADY[:2]), _history(tmp_path / "off.csv", off, STEADY)]
    )
    labels = [text.get_text() for text in history_figure(history).legends[0].get_texts()]
    cases = set(run_figures(on)["case"])
    assert set(run_figures(off)["case"]) == cases  # the two grids label their cases alike
    assert len(labels) == len(set(labels)) == 2 * len(cases)
