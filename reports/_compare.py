"""Comparing two runs (record directories) or two pytest-benchmark JSON files, metric by metric.

Quality figures (objective, coverage, expression count, transfer RMS, benchmark ``extra_info``) must not
change beyond a relative tolerance; times are judged by a statistical test (`reports._timing`): each
repetition's sequence time as a ratio to the median exact solver measured in the same run, slower or faster
only when Welch's t-test, adjusted over the comparison's cases, says so and the change is beyond a
threshold. A case with too few repetitions to test is judged against its history across commits
(`reports._history`), when given.
"""

from __future__ import annotations

import dataclasses
import json
import math
import numbers
import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd
from rich.markup import escape
from rich.table import Table

import harness
from registry import HarnessError
from reports._history import (
    HISTORY_COLUMNS,
    RUN_COLUMNS,
    Spread,
    read_history,
    run_identity,
    spreads,
)
from reports._tables import CASE_COLUMNS, SETTING_COLUMNS, rig_labels, setting_label, termination_counts
from reports._timing import (
    MIN_REFERENCE_SOLVERS,
    REFERENCE,
    TimingTest,
    case_samples,
    has_reference,
    judge_times,
    timing_samples,
    timing_test,
)

Kind = Literal["time", "quality"]
Verdict = Literal["same", "slower", "faster", "changed", "missing", "added"]
Value = float | str | tuple


@dataclass(frozen=True)
class Metric:
    """One figure of one case: a time (scalar seconds or ratio) or a quality value (scalar or vector).

    ``case`` is a benchmark's name or a run's case label (a tuple of `CASE_COLUMNS` values while reading);
    ``case_id`` is a run's case spelled out in full (`case_id`), empty for a benchmark.
    """

    case: Any
    name: str
    kind: Kind
    value: Value
    seconds: float | None = None  #: the absolute time behind a time metric
    case_id: str = ""
    samples: pd.DataFrame | None = None  #: a run's `timing_samples` of the case, behind a time metric
    column: str = "seconds"  #: the column of ``samples`` the metric's value sums (``ratio`` or ``seconds``)


@dataclass(frozen=True)
class Change:
    """How one metric moved from the old to the new run.

    ``old`` and ``new`` are shown values: for vectors (per expression, per J) the first element that differs,
    named in ``where``. ``ratio`` is new / old for times. ``spread`` is the history's spread of the figure
    when that judged the new value; ``termination`` how the new run's solves of a time ended.
    """

    case: str
    metric: str
    kind: Kind
    old: Value | None
    new: Value | None
    verdict: Verdict
    ratio: float | None = None
    where: str = ""
    spread: Spread | None = None
    termination: str = ""


@dataclass(frozen=True)
class Comparison:
    """All metric changes between two runs and the rules that judge them (``history``: the rule for times
    with a history, empty without one)."""

    old: str
    new: str
    threshold: float
    tolerance: float
    min_time: float
    time_basis: str
    changes: tuple[Change, ...]
    history: str = ""
    alpha: float = 0.01

    def regressions(self, *, fail_on_time: bool = False) -> list[Change]:
        """Changes that fail: any quality change or loss, and slower times if ``fail_on_time``."""
        failing: dict[Kind, set[Verdict]] = {
            "quality": {"changed", "missing"},
            "time": {"slower", "missing"} if fail_on_time else set(),
        }
        return [change for change in self.changes if change.verdict in failing[change.kind]]

    def warnings(self, *, fail_on_time: bool = False) -> list[Change]:
        """Slower times that do not fail (timing noise is a warning unless ``fail_on_time``)."""
        if fail_on_time:
            return []
        return [
            change
            for change in self.changes
            if change.kind == "time" and change.verdict in ("slower", "missing")
        ]


# -- reading metrics ---------------------------------------------------------------------------------------


def _case_labels(cases: Iterable[tuple]) -> dict[tuple, str]:
    """``rig/warp/solver`` of each case, plus the seed and settings that vary among ``cases``."""
    cases = list(cases)
    frame = pd.DataFrame(cases, columns=list(CASE_COLUMNS))
    settings = [
        c for c in ("rig_seed", *SETTING_COLUMNS) if frame[c].astype(object).fillna("none").nunique() > 1
    ]
    labels = rig_labels(frame["rig"].astype(str))
    return {
        case: "/".join(
            [labels[str(row["rig"])], str(row["warp"]), str(row["solver"])]
            + ([setting_label(row, settings)] if settings else [])
        )
        for case, (_, row) in zip(cases, frame.iterrows(), strict=True)
    }


def _identity_value(value: object) -> str:
    """A `CASE_COLUMNS` value as `case_id` spells it: ``none``, ``true``/``false``, a number in its shortest
    form whatever its type (``10`` for 10 and 10.0, ``0.3``), text as is."""
    if value is None:
        return "none"
    if isinstance(value, bool | np.bool_):
        return "true" if value else "false"
    if isinstance(value, numbers.Real):
        number = float(value)
        return str(int(number)) if number.is_integer() else repr(number)
    return str(value)


def case_id(case: tuple) -> str:
    """The stable identity of a run's case: every `CASE_COLUMNS` value, named, whatever else the run holds.

    Parameters
    ----------
    case : tuple
        The case's `CASE_COLUMNS` values (None where missing).

    Returns
    -------
    str
        ``rig=tiny; rig_seed=0; warp=big-eyes; mu=0.3; ...; solver=cpsat``: the rig as the run names it (a
        preset, or a rig file's path), numbers in their shortest form.
    """
    return "; ".join(
        f"{column}={_identity_value(value)}" for column, value in zip(CASE_COLUMNS, case, strict=True)
    )


def _case_keys(frame: pd.DataFrame) -> list[tuple]:
    return [
        tuple(None if pd.isna(v) else v for v in row)
        for row in frame[list(CASE_COLUMNS)].itertuples(index=False)
    ]


def _run_metrics(records: pd.DataFrame, ratios: bool) -> list[Metric]:
    """Metrics of a run keyed by case tuples; times as ratios to the baseline solver when ``ratios``.

    Quality comes from the first repetition (repetitions only differ in time); times are medians over
    repetitions, each carrying its absolute seconds for the noise floor (`_time_metrics`).
    """
    cells = records[records["kind"] == "cell"].sort_values("repetition")
    metrics = [
        Metric(case, "cell status per repetition", "quality", tuple(rows["status"].astype(str)))
        for case, rows in zip(*_grouped(cells), strict=True)
    ]
    first_repetition = records[records["repetition"] == records["repetition"].min()]
    ok = first_repetition[(first_repetition["kind"] == "cell") & (first_repetition["status"] == "ok")]
    for case, (_, cell) in zip(_case_keys(ok), ok.iterrows(), strict=True):
        metrics.append(Metric(case, "expressions", "quality", float(cell["n_expressions"])))
        if pd.notna(cell.get("min_expressions")):
            metrics.append(Metric(case, "minimum expressions", "quality", float(cell["min_expressions"])))
    expressions = first_repetition[
        (first_repetition["kind"] == "expression") & first_repetition["cell"].isin(ok["cell"])
    ].sort_values("expression")  # a cell stopped by its timeout keeps expressions; its status is compared
    for case, rows in zip(*_grouped(expressions), strict=True):
        metrics.append(
            Metric(case, "objective per expression", "quality", tuple(rows["objective"].astype(float)))
        )
        metrics.append(
            Metric(case, "shapes covered per expression", "quality", tuple(rows["covered"].astype(float)))
        )
    transfers = first_repetition[first_repetition["kind"] == "transfer"].sort_values("j")
    for transfer, of_method in transfers.groupby("transfer", sort=True):
        for case, rows in zip(*_grouped(of_method), strict=True):
            metrics.append(Metric(case, f"RMS {transfer} per J", "quality", tuple(rows["rms"].astype(float))))
    return metrics + _time_metrics(records, ratios)


def _time_metrics(records: pd.DataFrame, ratios: bool) -> list[Metric]:
    """Times of a run keyed by case tuples: the median sequence, as a ratio to the run's `REFERENCE` when
    ``ratios`` or in seconds, with every sample behind it (`reports._timing.timing_samples`)."""
    name = f"sequence / {REFERENCE}" if ratios else "sequence (s)"
    value = "ratio" if ratios else "seconds"
    metrics = []
    for case, rows in case_samples(timing_samples(records)).items():
        sequences = rows.groupby("cell")[["ratio", "seconds"]].sum()
        median = float(sequences[value].median())
        seconds = float(sequences["seconds"].median())
        metrics.append(Metric(case, name, "time", median, seconds, samples=rows, column=value))
    return metrics


def _grouped(frame: pd.DataFrame) -> tuple[list[tuple], list[pd.DataFrame]]:
    if frame.empty:
        return [], []
    groups = list(frame.groupby(list(CASE_COLUMNS), sort=True, dropna=False))
    return [tuple(None if pd.isna(v) else v for v in key) for key, _ in groups], [rows for _, rows in groups]


def _benchmark_metrics(path: Path) -> list[Metric]:
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
        benchmarks = document["benchmarks"]
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise HarnessError(f"{path}: not a pytest-benchmark JSON file ({error})") from None
    metrics = []
    for benchmark in benchmarks:
        name = benchmark.get("fullname") or benchmark["name"]
        stats = benchmark.get("stats") or {}
        if "median" in stats:
            metrics.append(Metric(name, "median time (s)", "time", float(stats["median"])))
        for key, value in sorted((benchmark.get("extra_info") or {}).items()):
            shown = (
                float(value)
                if isinstance(value, int | float) and not isinstance(value, bool)
                else json.dumps(value)
            )
            metrics.append(Metric(name, key, "quality", shown))
    return metrics


def _read_run(path: Path) -> pd.DataFrame:
    if not (path / "records").is_dir():
        raise HarnessError(
            f"{path}: neither a run directory (with records/) nor a pytest-benchmark JSON file"
        )
    return harness.read_records(path)


def read_metrics(old: Path, new: Path) -> tuple[list[Metric], list[Metric], str]:
    """Metrics of two run directories or two pytest-benchmark files, and how their times are measured.

    Runs are timed as ratios to their `REFERENCE` when both have one, else in seconds; their cases are
    labelled ``rig/warp/solver`` plus the settings that vary over both runs.

    Raises
    ------
    ValueError
        When a path is neither kind or the two kinds differ.
    """
    if old.is_file() != new.is_file():
        raise HarnessError(
            f"compare: {old} and {new} must both be run directories or both benchmark JSON files"
        )
    if old.is_file():
        return _benchmark_metrics(old), _benchmark_metrics(new), "median seconds per benchmark"
    old_records, new_records = _read_run(old), _read_run(new)
    ratios = _has_ratios(old_records) and _has_ratios(new_records)
    old_metrics, new_metrics = _run_metrics(old_records, ratios), _run_metrics(new_records, ratios)
    labels = _case_labels(sorted({metric.case for metric in old_metrics + new_metrics}, key=repr))
    old_metrics, new_metrics = (
        [
            dataclasses.replace(metric, case=labels[metric.case], case_id=case_id(metric.case))
            for metric in metrics
        ]
        for metrics in (old_metrics, new_metrics)
    )
    basis = (
        f"ratio to the {REFERENCE} in the same run"
        if ratios
        else f"seconds (fewer than {MIN_REFERENCE_SOLVERS} exact solvers in a group of a run)"
    )
    return old_metrics, new_metrics, basis


def changed_inputs(old: Path, new: Path) -> list[str]:
    """One line per rig of both runs whose content differs between them (``rig_digests`` of ``run.json``):
    changes of its cases may be the rig's doing, not the code's. Empty for benchmark files."""
    if old.is_file() or new.is_file():
        return []
    try:
        before, after = (harness.read_run(path).get("rig_digests") or {} for path in (old, new))
    except (OSError, ValueError):
        return []
    changed: dict[str, tuple[str, str]] = {}  # rig -> its first changed digests (a key per rig and seed)
    for key in sorted(set(before) & set(after)):
        if before[key] != after[key]:
            changed.setdefault(key.rpartition("@")[0] or key, (before[key], after[key]))
    return [
        f"rig {rig}: its content differs between the runs ({was[:15]}... -> {now[:15]}...); changes of its "
        "cases may be the rig's, not the code's"
        for rig, (was, now) in changed.items()
    ]


def one_machine(old: Path, new: Path) -> str | None:
    """The machine both runs ran on, when their ``run.json`` say the same host name, platform, core count and
    processor model (a model must be recorded), else None.

    The ratio to the `REFERENCE` cancels a machine's speed and its moments of load, but it couples the
    solvers of a group: with two exact solvers, one slowing down makes the other's ratio faster though its
    seconds did not move. On one machine the seconds tell the two apart (`_time_change`).
    """
    found = []
    for path in (old, new):
        try:
            found.append(harness.read_run(path).get("machine") or {})
        except (OSError, ValueError):
            return None
    keys = ("hostname", "platform", "cpu_count", "cpu_model")
    first, second = found
    if not first.get("cpu_model") or any(first.get(key) != second.get(key) for key in keys):
        return None
    return f"{first['hostname']}, {first['cpu_count']} CPUs, {first['cpu_model']}"


def _has_ratios(records: pd.DataFrame) -> bool:
    return has_reference(timing_samples(records))


def run_figures(run_dir: str | os.PathLike) -> pd.DataFrame:
    """The history rows of one run: each case's median sequence as a ratio to the run's `REFERENCE`.

    Parameters
    ----------
    run_dir : path
        A run directory (``harness run --out``) with at least `MIN_REFERENCE_SOLVERS` exact solvers in
        every group.

    Returns
    -------
    DataFrame with the `reports._history.HISTORY_COLUMNS`, one row per (case, figure), named as
    `compare` names them (cases labelled by the settings that vary within this run) and identified in full
    (`case_id`).

    Raises
    ------
    FileNotFoundError
        When ``run_dir`` holds no run.
    ValueError
        When it is not a run directory or a group of it has too few exact solvers for a reference.
    """
    run_dir = Path(run_dir)
    records = _read_run(run_dir)
    if not _has_ratios(records):
        raise HarnessError(
            f"{run_dir}: a group of cells has fewer than {MIN_REFERENCE_SOLVERS} exact solvers, so no "
            f"reference time and no ratios for the history"
        )
    metrics = _time_metrics(records, ratios=True)
    labels = _figure_labels(metrics)
    identity = run_identity(harness.read_run(run_dir))
    rows = [
        {
            **identity,
            "case": labels[m.case],
            "figure": m.name,
            "ratio": m.value,
            "seconds": m.seconds,
            "case_id": case_id(m.case),
        }
        for m in metrics
    ]
    return pd.DataFrame(rows, columns=list(HISTORY_COLUMNS))


def _figure_labels(metrics: list[Metric]) -> dict[tuple, str]:
    """The history's ``case`` label of each case of one run's time metrics."""
    return _case_labels(sorted({metric.case for metric in metrics}, key=repr))


def _history_spreads(
    path: Path, new: Path, *, window: int, k: float, tolerance: float, min_runs: int
) -> dict[tuple[str, str], Spread]:
    """Spreads of the figures in the history at ``path`` by (`case_id`, figure) over its commits
    (`reports._history.spreads`), leaving out the rows of run ``new`` itself."""
    if not (new / "records").is_dir():
        raise HarnessError(f"compare: a history applies to run directories, not to {new}")
    history = read_history(path)
    identity = run_identity(harness.read_run(new))
    own = (history[list(RUN_COLUMNS)] == pd.Series({c: identity[c] for c in RUN_COLUMNS})).all(axis=1)
    return spreads(history[~own], window=window, k=k, tolerance=tolerance, min_runs=min_runs)


# -- judging changes ---------------------------------------------------------------------------------------


def _close(old: Value, new: Value, tolerance: float) -> bool:
    if isinstance(old, float) and isinstance(new, float):
        if math.isnan(old) or math.isnan(new):
            return math.isnan(old) and math.isnan(new)
        return abs(new - old) <= tolerance * max(abs(old), abs(new))
    return old == new


def _quality_change(old: Metric, new: Metric, tolerance: float) -> Change:
    if isinstance(old.value, tuple) and isinstance(new.value, tuple):
        for position, (a, b) in enumerate(zip(old.value, new.value, strict=False)):
            if not _close(a, b, tolerance):
                return Change(old.case, old.name, "quality", a, b, "changed", where=f"at {position + 1}")
        if len(old.value) != len(new.value):
            where = f"length {len(old.value)} -> {len(new.value)}"
            return Change(
                old.case, old.name, "quality", len(old.value), len(new.value), "changed", where=where
            )
        last = old.value[-1] if old.value else None
        return Change(old.case, old.name, "quality", last, new.value[-1] if new.value else None, "same")
    verdict: Verdict = "same" if _close(old.value, new.value, tolerance) else "changed"
    return Change(old.case, old.name, "quality", old.value, new.value, verdict)


def _time_ratio(old: Metric, new: Metric) -> float:
    assert isinstance(old.value, float) and isinstance(new.value, float)
    return new.value / old.value if old.value > 0 else math.inf if new.value > 0 else 1.0


def _below_floor(old: Metric, new: Metric, min_time: float) -> bool:
    """Whether a time is under ``min_time`` seconds in both runs (timer noise)."""
    seconds = max(old.seconds or 0.0, new.seconds or 0.0)
    return (old.seconds is not None or new.seconds is not None) and seconds < min_time


def _time_tests(
    pairs: list[tuple[Metric, Metric]], *, min_time: float, alpha: float, threshold: float
) -> dict[int, TimingTest]:
    """The tests of one comparison's times with samples on both sides, judged as one family
    (`reports._timing.judge_times`), by position in ``pairs``."""
    tested = [
        index
        for index, (old, new) in enumerate(pairs)
        if old.kind == "time"
        and old.samples is not None
        and new.samples is not None
        and not _below_floor(old, new, min_time)
        and not math.isnan(_time_ratio(old, new))
    ]
    tests = [timing_test(pairs[i][0].samples, pairs[i][1].samples, value=pairs[i][1].column) for i in tested]
    return dict(zip(tested, judge_times(tests, alpha=alpha, threshold=threshold), strict=True))


def _held_in_seconds(change: Change, old: Metric, new: Metric, threshold: float) -> Change:
    """``change`` whose ratio to the `REFERENCE` was judged slower or faster, kept only when the median
    sequence also moved that way in seconds by more than ``threshold`` (both runs of one machine): else the
    reference moved, not the case, and the verdict is ``same``, saying so."""
    if change.verdict not in ("slower", "faster") or new.column != "ratio" or not old.seconds:
        return change
    seconds = (new.seconds or 0.0) / old.seconds
    held = seconds > 1.0 + threshold if change.verdict == "slower" else seconds < 1.0 / (1.0 + threshold)
    if held:
        return change
    note = f"; x{seconds:.2f} in seconds on one machine: the {REFERENCE} moved, not this case)"
    return dataclasses.replace(change, verdict="same", where=change.where[:-1] + note)


def _terminations(old: Metric, new: Metric) -> str:
    """How the new run's solves of a case ended, and the old run's before an arrow when they ended otherwise
    (a time that fell because the old run stopped at its limit is then seen as such)."""
    if new.samples is None:
        return ""
    now = termination_counts(new.samples)
    before = "" if old.samples is None else termination_counts(old.samples)
    return now if before in ("", now) else f"{before} → {now}"


def _time_change(
    old: Metric,
    new: Metric,
    *,
    threshold: float,
    min_time: float,
    test: TimingTest | None = None,
    spread: Spread | None = None,
    one_machine: bool = False,
) -> Change:
    """Judge a time.

    Under ``min_time`` seconds in both runs it is timer noise. With samples on both sides (a run's cases)
    its ``test`` (`_time_tests`) judges it; a case with too few samples to test is judged by the history's
    ``spread`` when there is one (slower above ``spread.high``, faster below ``spread.low``) and otherwise
    left untested. A benchmark's single median is judged by new / old against ``threshold``. On
    ``one_machine`` (`one_machine`) a ratio judged slower or faster must have moved the same way in seconds
    (`_held_in_seconds`).
    """
    ratio = _time_ratio(old, new)
    termination = _terminations(old, new)
    change = Change(old.case, old.name, "time", old.value, new.value, "same", ratio, termination=termination)
    if _below_floor(old, new, min_time):
        return dataclasses.replace(change, where=f"(< {min_time:g} s)")
    if math.isnan(ratio):
        return dataclasses.replace(
            change, verdict="changed" if math.isnan(old.value) != math.isnan(new.value) else "same"
        )
    if test is not None and (test.p is not None or spread is None):
        judged = dataclasses.replace(change, verdict=test.verdict, where=f"({test.describe()})")
        return _held_in_seconds(judged, old, new, threshold) if one_machine else judged
    if spread is not None:
        verdict = "slower" if new.value > spread.high else "faster" if new.value < spread.low else "same"
        judged = dataclasses.replace(change, verdict=verdict, where="(history)", spread=spread)
        return _held_in_seconds(judged, old, new, threshold) if one_machine else judged
    verdict = "slower" if ratio > 1.0 + threshold else "faster" if ratio < 1.0 / (1.0 + threshold) else "same"
    return dataclasses.replace(change, verdict=verdict)


def compare(
    old: str | os.PathLike,
    new: str | os.PathLike,
    *,
    threshold: float = 0.25,
    tolerance: float = 1e-7,
    min_time: float = 0.01,
    alpha: float = 0.01,
    history: str | os.PathLike | None = None,
    window: int = 10,
    spread: float = 3.0,
    min_runs: int = 5,
) -> Comparison:
    """Compare two runs (record directories) or two pytest-benchmark JSON files metric by metric.

    Parameters
    ----------
    old, new : path
        Two run directories (``harness run --out``) or two ``--benchmark-json`` files.
    threshold : float
        A time counts as slower only when new / old of the median sequence > 1 + threshold (0.25 = 25 %)
        (and the test is significant). With a history, the least margin above a figure's median, relative
        to it.
    tolerance : float
        Quality values count as changed when they differ by more than this, relative to the larger.
    min_time : float
        Seconds below which a run's time (in both runs) is timer noise and never counts as slower or
        faster. Benchmark medians (many rounds each) are always judged.
    alpha : float in (0, 1)
        Level of the two-sided tests of the cases' repetitions, Benjamini-Hochberg adjusted over all of them
        (`reports._timing.judge_times`).
    history : path, optional
        A history file (`reports.append_history`) of earlier runs' ratios. A case with too few repetitions
        to test whose figure has at least ``min_runs`` commits there (``new``'s own rows left out) is
        judged against their spread (`reports._history.spreads`): slower above ``median + max(spread *
        1.4826 MAD, threshold * median)`` of the per-commit medians of its last ``window`` commits, faster
        below the median by as much.
    window : int
        Latest commits of a figure in the history that give its spread (each commit counts once, with the
        median of its runs; runs from a dirty tree or without a commit are left out).
    spread : float
        Robust standard deviations (1.4826 MAD) a ratio may move from its history's median.
    min_runs : int
        Fewest commits of a figure in the history for it to be judged by the history.

    Returns
    -------
    Comparison
        Every metric of either side; one only in ``old`` is ``missing``, one only in ``new`` ``added``.

    Raises
    ------
    ValueError
        When a path is neither kind, the two kinds differ, a threshold or tolerance is negative, a history
        is given for benchmark files, or the history file is not one (`reports.HistoryError`).
    FileNotFoundError
        When ``history`` does not exist.
    """
    if min(threshold, tolerance, min_time, spread) < 0 or min(window, min_runs) < 1 or not 0 < alpha < 1:
        raise HarnessError(
            f"compare: threshold, tolerance, min_time and spread must be >= 0, window and min_runs >= 1 and "
            f"alpha in (0, 1), got {threshold}, {tolerance}, {min_time}, {spread}, {window}, {min_runs} and "
            f"{alpha}"
        )
    judged = (
        {}
        if history is None
        else _history_spreads(
            Path(history), Path(new), window=window, k=spread, tolerance=threshold, min_runs=min_runs
        )
    )
    old_metrics, new_metrics, basis = read_metrics(Path(old), Path(new))
    machine = None if Path(old).is_file() else one_machine(Path(old), Path(new))
    by_key = {(m.case, m.name): m for m in new_metrics}
    pairs = [(metric, by_key.pop((metric.case, metric.name), None)) for metric in old_metrics]
    found = [(metric, other) for metric, other in pairs if other is not None]
    tests = _time_tests(found, min_time=min_time, alpha=alpha, threshold=threshold)
    changes = [Change(m.case, m.name, m.kind, m.value, None, "missing") for m, o in pairs if o is None]
    for index, (metric, other) in enumerate(found):
        if metric.kind == "time":
            history_spread = judged.get((other.case_id, other.name))
            changes.append(
                _time_change(
                    metric,
                    other,
                    threshold=threshold,
                    min_time=min_time,
                    test=tests.get(index),
                    spread=history_spread,
                    one_machine=machine is not None,
                )
            )
        else:
            changes.append(_quality_change(metric, other, tolerance))
    changes += [Change(m.case, m.name, m.kind, None, m.value, "added") for m in by_key.values()]
    changes.sort(key=lambda change: change.case)
    floor = 0.0 if Path(old).is_file() else min_time  # benchmark medians are never floored
    rule = (
        ""
        if history is None
        else f"{history}: a case with too few repetitions is slower above median + max({spread:g} x 1.4826 "
        f"MAD, {threshold:.0%}) of its last {window} commits (at least {min_runs})"
    )
    return Comparison(str(old), str(new), threshold, tolerance, floor, basis, tuple(changes), rule, alpha)


# -- showing changes ---------------------------------------------------------------------------------------

_STYLES = {
    "same": "green",
    "faster": "cyan",
    "added": "dim",
    "slower": "yellow",
    "changed": "red",
    "missing": "red",
}


def _shown(value: Value | None) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)


def comparison_table(
    comparison: Comparison, *, fail_on_time: bool = False, only_changes: bool = False
) -> Table:
    """A rich table with one row per metric: case, metric, old, new, ratio, verdict (failures in red) and,
    for times, how the new run's solves ended; with a history, also the spread that judged a time (median
    and limits over the commits counted)."""
    failing = set(comparison.regressions(fail_on_time=fail_on_time))
    floor = f" (times under {comparison.min_time:g} s are noise)" if comparison.min_time else ""
    history = f"; history {comparison.history}" if comparison.history else ""
    table = Table(
        title=f"{comparison.old} -> {comparison.new}",
        caption=f"times: {comparison.time_basis} (time limits and errors charged at the limit); slower or "
        f"faster means Welch's t-test over the repetitions, Benjamini-Hochberg adjusted over the "
        f"comparison's tests, q < {comparison.alpha:g} and a median change beyond "
        f"{comparison.threshold:.0%}{floor}; quality tolerance {comparison.tolerance:g} relative"
        f"{history}",
    )
    columns = ["case", "metric", "old", "new", "new/old", "verdict", "termination"]
    columns += ["history"] if history else []
    for column in columns:
        table.add_column(column, justify="right" if column in ("old", "new", "new/old") else "left")
    for change in comparison.changes:
        if only_changes and change.verdict == "same":
            continue
        style = "bold red" if change in failing else _STYLES[change.verdict]
        verdict = f"{change.verdict} {change.where}".strip() + (" (fails)" if change in failing else "")
        ratio = "" if change.ratio is None else f"{change.ratio:.3f}"
        cells = [escape(change.case), change.metric, _shown(change.old), _shown(change.new), ratio, verdict]
        cells.append(change.termination)
        table.add_row(*cells, *([_spread_text(change.spread)] if history else []), style=style)
    return table


def _spread_text(spread: Spread | None) -> str:
    if spread is None:
        return ""
    limits = f"[{spread.low:.4g}, {spread.high:.4g}]"
    return f"median {spread.median:.4g} in {limits} over {spread.commits} commits"
