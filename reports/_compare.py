"""Comparing two runs (record directories) or two pytest-benchmark JSON files, metric by metric.

Quality figures (objective, coverage, expression count, transfer RMS, benchmark ``extra_info``) must not
change beyond a relative tolerance. Times are judged case by case against the same case's times in the
other run, paired expression by expression where both runs solved the same problem (`reports._timing`),
by the paired test and verdicts of `reports._paired` (slower, faster, same, inconclusive); and only when
both runs ran on one machine (`one_machine`): a time measured elsewhere is shown, never judged. Two
commits are best timed side by side, in one job: ``harness compare --commits``.
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
from reports._paired import PairedTest, judge, paired_test
from reports._tables import CASE_COLUMNS, SETTING_COLUMNS, rig_labels, setting_label, termination_counts
from reports._timing import case_samples, clock, paired_units, timing_samples

Kind = Literal["time", "quality"]
Verdict = Literal["same", "slower", "faster", "inconclusive", "untested", "changed", "missing", "added"]
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
    seconds: float | None = None  #: the median sequence seconds behind a time metric
    case_id: str = ""
    samples: pd.DataFrame | None = None  #: a run's `timing_samples` of the case, behind a time metric


@dataclass(frozen=True)
class Change:
    """How one metric moved from the old to the new run.

    ``old`` and ``new`` are shown values: for vectors (per expression, per J) the first element that differs,
    named in ``where``. ``ratio`` is new / old for times (the paired geometric mean when tested);
    ``termination`` how the new run's solves of a time ended.
    """

    case: str
    metric: str
    kind: Kind
    old: Value | None
    new: Value | None
    verdict: Verdict
    ratio: float | None = None
    where: str = ""
    termination: str = ""


@dataclass(frozen=True)
class Comparison:
    """All metric changes between two runs and the rules that judge them (``machine``: the one machine both
    runs ran on, empty when they did not, and then no time is judged)."""

    old: str
    new: str
    threshold: float
    tolerance: float
    min_time: float
    time_basis: str
    changes: tuple[Change, ...]
    machine: str = ""
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


def _run_metrics(records: pd.DataFrame) -> list[Metric]:
    """Metrics of a run keyed by case tuples.

    Quality comes from every repetition (each repeats its cells with its own solver and scan seeds, the
    same in both runs): a repetition after the first names its metrics ``..., repetition R``. Times are
    the median sequence over repetitions, with every sample behind it (`_time_metrics`).
    """
    cells = records[records["kind"] == "cell"].sort_values("repetition")
    metrics = [
        Metric(case, "cell status per repetition", "quality", tuple(rows["status"].astype(str)))
        for case, rows in zip(*_grouped(cells), strict=True)
    ]
    first = records["repetition"].min()
    for repetition, of_repetition in records.groupby("repetition", sort=True):
        metrics += _quality_metrics(
            of_repetition, "" if repetition == first else f", repetition {repetition}"
        )
    return metrics + _time_metrics(records)


def _quality_metrics(records: pd.DataFrame, suffix: str) -> list[Metric]:
    """The quality metrics of one repetition's records (names ending in ``suffix``)."""
    metrics = []
    ok = records[(records["kind"] == "cell") & (records["status"] == "ok")]
    for case, (_, cell) in zip(_case_keys(ok), ok.iterrows(), strict=True):
        metrics.append(Metric(case, f"expressions{suffix}", "quality", float(cell["n_expressions"])))
        if pd.notna(cell.get("min_expressions")):
            metrics.append(
                Metric(case, f"minimum expressions{suffix}", "quality", float(cell["min_expressions"]))
            )
    expressions = records[(records["kind"] == "expression") & records["cell"].isin(ok["cell"])].sort_values(
        "expression"
    )  # a cell stopped by its timeout keeps expressions; its status is compared
    for case, rows in zip(*_grouped(expressions), strict=True):
        objectives = tuple(rows["objective"].astype(float))
        metrics.append(Metric(case, f"objective per expression{suffix}", "quality", objectives))
        covered = tuple(rows["covered"].astype(float))
        metrics.append(Metric(case, f"shapes covered per expression{suffix}", "quality", covered))
    transfers = records[records["kind"] == "transfer"].sort_values("j")
    for transfer, of_method in transfers.groupby("transfer", sort=True):
        for case, rows in zip(*_grouped(of_method), strict=True):
            rms = tuple(rows["rms"].astype(float))
            metrics.append(Metric(case, f"RMS {transfer} per J{suffix}", "quality", rms))
    return metrics


#: Name of every run's time metric.
SEQUENCE = "sequence (s)"


def _time_metrics(records: pd.DataFrame) -> list[Metric]:
    """Times of a run keyed by case tuples: the median sequence seconds over repetitions, with every solve
    behind it (`reports._timing.timing_samples`)."""
    metrics = []
    for case, rows in case_samples(timing_samples(records)).items():
        median = float(rows.groupby("cell")["seconds"].sum().median())
        metrics.append(Metric(case, SEQUENCE, "time", median, median, samples=rows))
    return metrics


def _grouped(frame: pd.DataFrame) -> tuple[list[tuple], list[pd.DataFrame]]:
    if frame.empty:
        return [], []
    groups = list(frame.groupby(list(CASE_COLUMNS), sort=True, dropna=False))
    return [tuple(None if pd.isna(v) else v for v in key) for key, _ in groups], [rows for _, rows in groups]


def _benchmark_metrics(path: Path) -> list[Metric]:
    """The metrics of a pytest-benchmark JSON file: each benchmark's median time and its ``extra_info``.

    Raises
    ------
    HarnessError
        One line naming the file (and the benchmark) when it is not such a file: not JSON, no
        ``benchmarks`` list, a benchmark without a name, a median that is not a number, ...
    """
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except RecursionError:
        raise HarnessError(f"{path}: not a pytest-benchmark JSON file (nested too deeply)") from None
    except (OSError, ValueError) as error:
        raise HarnessError(f"{path}: not a pytest-benchmark JSON file ({error})") from None
    benchmarks = document.get("benchmarks") if isinstance(document, dict) else None
    if not isinstance(benchmarks, list):
        raise HarnessError(f"{path}: not a pytest-benchmark JSON file (no 'benchmarks' list)")
    metrics = []
    for position, benchmark in enumerate(benchmarks):
        metrics += _one_benchmark(path, position, benchmark)
    return metrics


def _finite_number(value: object) -> bool:
    """Whether ``value`` is a number (not a flag) that a float holds finitely."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return False
    try:
        return math.isfinite(float(value))
    except OverflowError:
        return False


def _one_benchmark(path: Path, position: int, benchmark: object) -> list[Metric]:
    """The metrics of one entry of a pytest-benchmark file's ``benchmarks`` (HarnessError naming it)."""

    def refuse(what: str) -> HarnessError:
        return HarnessError(f"{path}: benchmark {position + 1} {what}")

    if not isinstance(benchmark, dict):
        raise refuse("is not an object")
    name = benchmark.get("fullname") or benchmark.get("name")
    if not isinstance(name, str) or not name:
        raise refuse("has no name")
    stats, extra = benchmark.get("stats") or {}, benchmark.get("extra_info") or {}
    if not isinstance(stats, dict) or not isinstance(extra, dict):
        raise refuse(f"({name}): its 'stats' and 'extra_info' must be objects")
    metrics = []
    if "median" in stats:
        median = stats["median"]
        if not _finite_number(median):
            raise refuse(f"({name}): its median {median!r:.40} is not a number of seconds")
        metrics.append(Metric(name, "median time (s)", "time", float(median)))
    for key, value in sorted(extra.items()):
        try:
            shown = float(value) if _finite_number(value) else json.dumps(value)
        except (RecursionError, ValueError):
            raise refuse(f"({name}): its extra_info {key!r:.40} cannot be shown") from None
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

    Runs' cases are labelled ``rig/warp/solver`` plus the settings that vary over both runs.

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
    old_metrics, new_metrics = _run_metrics(_read_run(old)), _run_metrics(_read_run(new))
    labels = _case_labels(sorted({metric.case for metric in old_metrics + new_metrics}, key=repr))
    old_metrics, new_metrics = (
        [
            dataclasses.replace(metric, case=labels[metric.case], case_id=case_id(metric.case))
            for metric in metrics
        ]
        for metrics in (old_metrics, new_metrics)
    )
    basis = "each case's solves paired expression by expression, CPU seconds where both runs recorded them"
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

    Times are only judged between two runs of one machine: seconds measured on another say as much about
    the machine as about the code.
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


# -- judging changes ---------------------------------------------------------------------------------------


def _close(old: Value, new: Value, tolerance: float) -> bool:
    if isinstance(old, float) and isinstance(new, float):
        if math.isnan(old) or math.isnan(new):
            return math.isnan(old) and math.isnan(new)
        if math.isinf(old) or math.isinf(new):
            return old == new
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
) -> dict[int, tuple[PairedTest, int]]:
    """The paired tests of one comparison's times with samples on both sides, judged as one family
    (`reports._paired.judge`), with the expressions left out of each; by position in ``pairs``."""
    tested, tests, left = [], [], []
    for index, (old, new) in enumerate(pairs):
        if (
            old.kind != "time"
            or old.samples is None
            or new.samples is None
            or _below_floor(old, new, min_time)
        ):
            continue
        column = clock(old.samples, new.samples)
        units, unit, left_out = paired_units(old.samples, new.samples, column)
        samples = len(old.samples) + len(new.samples)
        name = "cpu" if column == "cpu" else "wall"
        tests.append(paired_test(units, samples=samples, clock=name, unit=unit, alpha=alpha))
        tested.append(index)
        left.append(left_out)
    judged = judge(tests, alpha=alpha, threshold=threshold)
    return {index: (test, left_out) for index, test, left_out in zip(tested, judged, left, strict=True)}


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
    tested: tuple[PairedTest, int] | None = None,
    machine: str | None = None,
) -> Change:
    """Judge a time.

    Under ``min_time`` seconds in both runs it is timer noise. Two runs of different machines (``machine``
    None) are never judged. A run's case is judged by its paired test (`_time_tests`), its ratio the
    test's; a benchmark's single median by new / old against ``threshold``.
    """
    ratio = _time_ratio(old, new)
    termination = _terminations(old, new)
    change = Change(old.case, old.name, "time", old.value, new.value, "same", ratio, termination=termination)
    if math.isnan(ratio) or math.isinf(ratio):
        changed = math.isnan(old.value) != math.isnan(new.value) or math.isinf(ratio)
        return dataclasses.replace(change, verdict="changed" if changed else "same")
    if _below_floor(old, new, min_time):
        return dataclasses.replace(change, verdict="untested", where=f"(< {min_time:g} s)")
    if old.samples is not None and machine is None:
        return dataclasses.replace(
            change, verdict="untested", where="(other machine: use harness compare --commits)"
        )
    if tested is not None:
        test, left_out = tested
        note = f"; {left_out} expressions solved other problems" if left_out else ""
        return dataclasses.replace(
            change, verdict=test.verdict, ratio=test.ratio, where=f"({test.describe()}{note})"
        )
    verdict = "slower" if ratio > 1.0 + threshold else "faster" if ratio < 1.0 / (1.0 + threshold) else "same"
    return dataclasses.replace(change, verdict=verdict)


def compare(
    old: str | os.PathLike,
    new: str | os.PathLike,
    *,
    threshold: float = 0.1,
    tolerance: float = 1e-7,
    min_time: float = 0.01,
    alpha: float = 0.01,
) -> Comparison:
    """Compare two runs (record directories) or two pytest-benchmark JSON files metric by metric.

    Parameters
    ----------
    old, new : path
        Two run directories (``harness run --out``) or two ``--benchmark-json`` files.
    threshold : float
        Least relative change of a time that counts (`reports._paired.judge`): slower beyond ``1 +
        threshold`` when the test says so, the same when the interval lies within it. A benchmark's single
        median is slower beyond it.
    tolerance : float
        Quality values count as changed when they differ by more than this, relative to the larger.
    min_time : float
        Seconds below which a run's median sequence (in both runs) is timer noise and left untested.
        Benchmark medians (many rounds each) are always judged.
    alpha : float in (0, 1)
        Level of the paired tests of the cases' times, Benjamini-Hochberg adjusted over all of them, and of
        their intervals.

    Returns
    -------
    Comparison
        Every metric of either side; one only in ``old`` is ``missing``, one only in ``new`` ``added``.
        Times of two runs that did not run on one machine (`one_machine`) are ``untested``.

    Raises
    ------
    HarnessError
        When a path is neither kind, the two kinds differ, or a threshold or tolerance is negative.
    """
    if min(threshold, tolerance, min_time) < 0 or not 0 < alpha < 1:
        raise HarnessError(
            f"compare: threshold, tolerance and min_time must be >= 0 and alpha in (0, 1), got {threshold}, "
            f"{tolerance}, {min_time} and {alpha}"
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
            changes.append(
                _time_change(
                    metric,
                    other,
                    threshold=threshold,
                    min_time=min_time,
                    tested=tests.get(index),
                    machine=machine,
                )  # fmt: skip
            )
        else:
            changes.append(_quality_change(metric, other, tolerance))
    changes += [Change(m.case, m.name, m.kind, None, m.value, "added") for m in by_key.values()]
    changes.sort(key=lambda change: change.case)
    floor = 0.0 if Path(old).is_file() else min_time  # benchmark medians are never floored
    return Comparison(
        str(old), str(new), threshold, tolerance, floor, basis, tuple(changes), machine or "", alpha
    )


# -- showing changes ---------------------------------------------------------------------------------------

_STYLES = {
    "same": "green",
    "faster": "cyan",
    "inconclusive": "dim",
    "untested": "dim",
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
    for times, how the new run's solves ended."""
    failing = set(comparison.regressions(fail_on_time=fail_on_time))
    floor = f" (sequences under {comparison.min_time:g} s are left untested)" if comparison.min_time else ""
    machine = (
        f"both runs on {comparison.machine}"
        if comparison.machine
        else "the runs name different machines (or none): times are shown, not judged"
    )
    table = Table(
        title=f"{comparison.old} -> {comparison.new}",
        caption=f"times: {comparison.time_basis} (time limits and errors charged at the limit), {machine}; "
        f"slower or faster: the paired t-test, Benjamini-Hochberg adjusted over the comparison's tests, q < "
        f"{comparison.alpha:g} and a ratio beyond {1 + comparison.threshold:.2f}; same: the interval within "
        f"it{floor}; quality tolerance {comparison.tolerance:g} relative",
    )
    for column in ("case", "metric", "old", "new", "new/old", "verdict", "termination"):
        table.add_column(column, justify="right" if column in ("old", "new", "new/old") else "left")
    for change in comparison.changes:
        if only_changes and change.verdict in ("same", "untested"):
            continue
        style = "bold red" if change in failing else _STYLES[change.verdict]
        verdict = f"{change.verdict} {change.where}".strip() + (" (fails)" if change in failing else "")
        ratio = "" if change.ratio is None else f"{change.ratio:.3f}"
        cells = [escape(change.case), change.metric, _shown(change.old), _shown(change.new), ratio, verdict]
        table.add_row(*cells, change.termination, style=style)
    return table
