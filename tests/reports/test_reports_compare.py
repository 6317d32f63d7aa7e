"""`harness compare` of two runs: quality changes fail; times are judged per case against themselves, paired
expression by expression, and only between runs of one machine; identical runs pass.

The "slowed" and "worse" runs are fabricated exactly as a solver plugin that sleeps, or one that drops a shape
from its answer, would leave them in the records.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pyarrow as pa
import pytest
from click.testing import CliRunner

from reports import compare
from reports._compare import SEQUENCE
from reports._paired import PairedTest, judge, paired_test
from reports.cli import compare as compare_command

TIMES = {"naive-pulp-cbc": 2.0, "highs": 0.02, "cpsat": 0.03, "greedy": 0.001}
#: naive-pulp-cbc sleeps 2 s more per solve
SLOW = TIMES | {"naive-pulp-cbc": 4.0}
#: one machine (the processor model recorded), and enough repetitions for the test, each solver's time
#: wobbling by up to 5 % from one to the next
TESTED = {"repetitions": 5, "wobble": 0.05, "cpu_model": "Test CPU @ 3 GHz"}


def _invoke(*args: object):
    result = CliRunner().invoke(compare_command, [str(a) for a in args], catch_exceptions=False)
    print(result.output)
    return result


def _verdicts(comparison, verdict):
    return sorted((c.case.rsplit("/", 1)[-1], c.metric) for c in comparison.changes if c.verdict == verdict)


def _time(comparison, solver: str):
    """The one time change of ``solver``'s case."""
    (change,) = [c for c in comparison.changes if c.kind == "time" and c.case.endswith(f"/{solver}")]
    return change


def test_identical_runs_pass(make_run):
    old, new = make_run("old", **TESTED), make_run("new", **TESTED)
    comparison = compare(old, new)
    assert {c.verdict for c in comparison.changes} - {"untested"} == {"same"}
    assert _time(comparison, "greedy").verdict == "untested"  # 3 ms sequences: under the noise floor
    assert _time(comparison, "highs").where.startswith("(x1 [1, 1], q=1 of 3, 15 expression repetitions")
    assert "CPU" in _time(comparison, "highs").where
    other_noise = make_run("other-noise", **TESTED, wobble_seed=1)  # the same code on another moment
    assert _verdicts(compare(old, other_noise), "slower") == []
    result = _invoke(old, new, "--fail-on-time")
    assert result.exit_code == 0
    assert "0 regressions, 0 timing warnings" in result.output


def test_a_slowed_solver_warns_by_default_and_fails_with_fail_on_time(make_run):
    one = {"repetitions": 1, "cpu_model": "Test CPU"}
    untested = compare(make_run("old-1", **one), make_run("new-1", seconds=SLOW, **one))
    assert _verdicts(untested, "slower") == []  # 3 expressions, 1 repetition: too few units to test
    assert _time(untested, "naive-pulp-cbc").where.startswith("(untested: ")

    old, new = make_run("old", **TESTED), make_run("new", seconds=SLOW, **TESTED)
    comparison = compare(old, new)
    assert _verdicts(comparison, "slower") == [("naive-pulp-cbc", SEQUENCE)]
    assert _verdicts(comparison, "faster") == []
    slower = _time(comparison, "naive-pulp-cbc")
    assert slower.ratio == pytest.approx(2.0, rel=0.05) and slower.where.startswith("(x2")
    assert comparison.regressions() == []
    assert len(comparison.warnings()) == 1

    result = _invoke(old, new)
    assert result.exit_code == 0
    assert "0 regressions, 1 timing warnings" in result.output
    result = _invoke(old, new, "--fail-on-time")
    assert result.exit_code == 1
    assert "1 regressions" in result.output


def test_runs_of_two_machines_are_shown_but_never_judged(make_run):
    """Seconds measured on another machine say as much about the machine as about the code: a baseline made
    elsewhere (or one that does not name its processor) never judges a time."""
    old = make_run("old", **TESTED)
    new = make_run("new", seconds=SLOW, **TESTED | {"cpu_model": "Other CPU @ 2 GHz"})
    comparison = compare(old, new)
    naive = _time(comparison, "naive-pulp-cbc")
    assert naive.verdict == "untested" and "other machine" in naive.where
    assert naive.ratio == pytest.approx(2.0)  # shown
    unknown = compare(make_run("old-u", repetitions=5), make_run("new-u", seconds=SLOW, repetitions=5))
    assert _verdicts(unknown, "slower") == [] and comparison.machine == ""


def test_each_solver_is_judged_against_itself(make_run):
    """One solver ten times slower moves its own ratio only: the others keep theirs, and get no verdict."""
    slow = TIMES | {"highs": 0.2}
    comparison = compare(make_run("old", **TESTED), make_run("new", seconds=slow, **TESTED))
    assert _verdicts(comparison, "slower") == [("highs", SEQUENCE)]
    assert _verdicts(comparison, "faster") == []
    for solver in ("cpsat", "naive-pulp-cbc"):
        assert _time(comparison, solver).verdict == "same"


def test_a_threshold_decides_what_is_slower(make_run):
    old, new = make_run("old", **TESTED), make_run("new", seconds=SLOW, **TESTED)
    assert _verdicts(compare(old, new, threshold=1.5), "slower") == []
    assert _verdicts(compare(old, new, threshold=0.5), "slower") == [("naive-pulp-cbc", SEQUENCE)]


def test_times_are_wall_seconds_when_a_run_recorded_no_cpu_time(make_run):
    old, new = make_run("old", **TESTED, cpu=False), make_run("new", seconds=SLOW, **TESTED)
    slower = _time(compare(old, new), "naive-pulp-cbc")
    assert slower.verdict == "slower" and "wall" in slower.where and "CPU" not in slower.where


def test_a_solver_that_drops_a_shape_fails(make_run, fabric):
    worse = [fabric["optimal"][0], ["smile_L", "smile_R"], fabric["optimal"][2]]
    old = make_run("old")
    new = make_run(
        "new",
        sequences={
            "naive-pulp-cbc": fabric["optimal"],
            "highs": worse,
            "cpsat": fabric["optimal"],
            "greedy": fabric["greedy"],
        },
    )
    comparison = compare(old, new)
    changed = {(c.case.rsplit("/", 1)[-1], c.metric): c for c in comparison.changes if c.verdict == "changed"}
    metrics = ["RMS ebfr per J", "objective per expression", "shapes covered per expression"]
    assert sorted(changed) == sorted(  # dt ignores the expressions: its RMS stays; both repetitions change
        ("highs", f"{metric}{suffix}") for metric in metrics for suffix in ("", ", repetition 1")
    )
    objective = changed[("highs", "objective per expression")]
    weights = fabric["weights"]
    assert objective.where == "at 2"
    assert objective.old == pytest.approx(weights["smile_L"] + weights["smile_R"] + weights["noseWrinkle"])
    assert objective.new == pytest.approx(weights["smile_L"] + weights["smile_R"])
    assert len(comparison.regressions()) == 6
    result = _invoke(old, new, "--only-changes")
    assert result.exit_code == 1
    assert "FAIL" in result.output and "6 regressions" in result.output
    assert "objective per expression" in result.output and "browUp_L" not in result.output


def test_quality_changes_within_the_tolerance_pass(make_run):
    old, new = make_run("old"), make_run("new", objective_scale=1 + 1e-12)
    assert compare(old, new).regressions() == []
    changed = compare(old, new, tolerance=1e-13).regressions()
    assert {c.metric for c in changed} == {
        "objective per expression",
        "objective per expression, repetition 1",
    }


def test_a_change_in_a_later_repetition_is_found(make_run):
    """Quality is compared in every repetition, not only the first."""
    import pyarrow.parquet as pq

    old, new = make_run("old"), make_run("new")
    for part in (new / "records").glob("*.parquet"):
        table = pq.read_table(part)
        frame = table.to_pandas()
        later = (frame["repetition"] == 1) & (frame["transfer"] == "ebfr")
        frame.loc[later, "rms"] *= 1.01
        pq.write_table(pa.Table.from_pandas(frame, schema=table.schema, preserve_index=False), part)
    changed = {c.metric for c in compare(old, new).regressions()}
    assert changed == {"RMS ebfr per J, repetition 1"}


def test_a_cell_that_errors_in_the_new_run_fails(make_run, fabric):
    old = make_run("old")
    new = make_run(
        "new",
        sequences={
            "naive-pulp-cbc": fabric["optimal"],
            "highs": fabric["optimal"],
            "greedy": fabric["greedy"],
        },
        skipped={"cpsat": "ortools failed to import"},
    )
    comparison = compare(old, new)
    statuses = [c for c in comparison.regressions() if c.metric == "cell status per repetition"]
    assert [(c.old, c.new, c.where) for c in statuses] == [("ok", "skipped", "at 1")]
    assert {c.verdict for c in comparison.regressions()} == {"changed", "missing"}


def _benchmark_file(path, median: float, objective: float):
    document = {
        "benchmarks": [
            {
                "name": "test_first_expression[female-highs]",
                "fullname": "tests/benchmarks/test_bench_solvers.py::test_first_expression[female-highs]",
                "stats": {"median": median, "mean": median, "min": median},
                "extra_info": {"objective": objective, "backend": "highs 1.12.0"},
            }
        ]
    }
    path.write_text(json.dumps(document))
    return path


def test_benchmark_files_compare_median_times_and_extra_info(tmp_path):
    old = _benchmark_file(tmp_path / "old.json", 0.010, 12.5)
    assert compare(old, _benchmark_file(tmp_path / "same.json", 0.011, 12.5)).regressions() == []
    slower = compare(old, _benchmark_file(tmp_path / "slow.json", 0.020, 12.5))
    assert _verdicts(slower, "slower") == [
        ("test_bench_solvers.py::test_first_expression[female-highs]", "median time (s)")
    ]
    assert slower.regressions() == [] and len(slower.regressions(fail_on_time=True)) == 1
    worse = compare(old, _benchmark_file(tmp_path / "worse.json", 0.010, 12.0))
    assert [(c.metric, c.old, c.new) for c in worse.regressions()] == [("objective", 12.5, 12.0)]
    assert _invoke(old, tmp_path / "worse.json").exit_code == 1


def test_unusable_inputs_exit_2_with_one_line(make_run, tmp_path):
    run = make_run("run")
    (tmp_path / "empty").mkdir()
    (tmp_path / "junk.json").write_text("[1, 2")
    result = _invoke(run, tmp_path / "empty")
    assert result.exit_code == 2
    assert "neither a run directory (with records/) nor a pytest-benchmark JSON file" in result.output
    result = _invoke(tmp_path / "junk.json", tmp_path / "junk.json")
    assert result.exit_code == 2 and "junk.json: not a pytest-benchmark JSON file" in result.output
    result = _invoke(run, tmp_path / "junk.json")
    assert (
        result.exit_code == 2 and "must both be run directories or both benchmark JSON files" in result.output
    )
    with pytest.raises(ValueError, match="threshold, tolerance and min_time must be >= 0"):
        compare(run, run, threshold=-1)


def test_an_exact_solver_that_fails_in_the_new_run_is_a_regression(make_run, fabric):
    old = make_run("old")
    new = make_run(
        "new",
        sequences={"highs": fabric["optimal"], "cpsat": fabric["optimal"], "greedy": fabric["greedy"]},
        skipped={"naive-pulp-cbc": "pulp failed to import"},
    )
    comparison = compare(old, new)
    failing = {(c.case.rsplit("/", 1)[-1], c.metric) for c in comparison.regressions()}
    assert ("naive-pulp-cbc", "cell status per repetition") in failing
    assert {solver for solver, _ in failing} == {"naive-pulp-cbc"}
    assert ("naive-pulp-cbc", SEQUENCE) in _verdicts(comparison, "missing")
    assert _invoke(old, new).exit_code == 1


def test_times_below_the_noise_floor_are_not_judged(make_run):
    old = make_run("old", **TESTED)
    new = make_run("new", seconds=SLOW | {"greedy": 0.002}, **TESTED)  # greedy 2x slower, in ms
    greedy = _time(compare(old, new), "greedy")
    assert (greedy.verdict, greedy.where) == ("untested", "(< 0.01 s)")
    assert greedy.ratio == pytest.approx(2.0)
    assert _time(compare(old, new, min_time=0.0), "greedy").verdict == "slower"


def _units(rng: np.random.Generator, scale: float, count: int, sd: float = 0.3) -> pd.DataFrame:
    """``count`` paired units of one case: old and new log-normal around 1 and ``scale``, sd ``sd`` on a
    log scale each."""
    return pd.DataFrame(
        {"old": np.exp(rng.normal(0.0, sd, count)), "new": scale * np.exp(rng.normal(0.0, sd, count))}
    )


def _family(rng: np.random.Generator, scales: list[float], count: int) -> list[PairedTest]:
    tests = [
        paired_test(
            _units(rng, scale, count), samples=2 * count, clock="thread", unit="instances", alpha=0.01
        )
        for scale in scales
    ]
    return judge(tests, alpha=0.01, threshold=0.0)


def test_the_tests_of_one_comparison_are_judged_as_one_family():
    """Eight cases of runs of the same code, 500 times: unadjusted, about 1 - 0.99^8 = 8 % of the
    comparisons would hold a verdict of slower or faster; adjusted as one family, at most about alpha =
    1 %. A true 2x slow-down of one case among them is still found at 16 units."""
    rng = np.random.default_rng(7)
    families = [_family(rng, [1.0] * 8, 8) for _ in range(500)]
    raw = sum(any(test.p < 0.01 for test in family) for family in families)
    judged = sum(any(test.verdict in ("slower", "faster") for test in family) for family in families)
    assert raw >= 25, raw  # what the adjustment is for
    assert judged <= 10, judged
    assert all(test.family == 8 and test.q >= test.p for family in families for test in family)

    slowed = [_family(rng, [2.0, *[1.0] * 7], 16)[0] for _ in range(200)]
    assert sum(test.verdict == "slower" for test in slowed) >= 190
    assert "q=" in slowed[0].describe() and "of 8" in slowed[0].describe()


def test_untested_cases_are_not_in_the_family():
    rng = np.random.default_rng(0)
    few = paired_test(_units(rng, 3.0, 2), samples=4, clock="thread", unit="instances", alpha=0.01)
    slow = paired_test(_units(rng, 3.0, 8), samples=16, clock="thread", unit="instances", alpha=0.01)
    judged_few, judged_slow = judge([few, slow], alpha=0.01, threshold=0.25)
    assert judged_few.p is None and judged_few.q is None and judged_few.verdict == "untested"
    assert judged_slow.family == 1 and judged_slow.q == pytest.approx(judged_slow.p)
    assert judged_slow.verdict == "slower"


def test_compare_says_when_a_rigs_content_differs_between_the_runs(make_run):
    old, new = make_run("old"), make_run("new")
    for run, digest, seeded in ((old, "a", "d"), (new, "b", "e")):  # (a generated rig differs per seed)
        document = json.loads((run / "run.json").read_text())
        document["rig_digests"] = {
            "face@0": "sha256:" + digest * 64,
            "face@1": "sha256:" + seeded * 64,
            "tiny@0": "sha256:" + "c" * 64,
        }
        (run / "run.json").write_text(json.dumps(document))
    result = _invoke(old, new)
    assert result.exit_code == 0, result.output
    flat = " ".join(result.output.split())
    assert flat.count("inputs differ:") == 1 and flat.count("rig face:") == 1 and "tiny" not in flat
    assert (
        "inputs differ: rig face: its content differs between the runs (sha256:aaaaaaaa... -> "
        "sha256:bbbbbbbb...); changes of its cases may be the rig's, not the code's" in flat
    )
