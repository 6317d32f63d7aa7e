"""The verdicts of a timing session between two commits (``harness compare --commits BASE HEAD``).

Every case of the suite (``rig/warp/solver``, ``rig/warp/transfer:method`` and the transfer's first call)
is judged on its own paired units (`reports._paired`). Beside the verdicts, what would make them
meaningless is said, never hidden: instances whose digests differ between the commits (the change altered
the problems, so they are not timed against each other), answers the independent check rejected or exact
solvers that disagree (a failure of its own), and what could not be measured at all.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import pandas as pd
from rich.markup import escape
from rich.table import Table

from harness import Measurement
from reports._paired import PairedTest, judge, paired_test, per_solve, unit_values

_STYLES = {"same": "green", "faster": "cyan", "slower": "yellow", "inconclusive": "dim", "untested": "dim"}


@dataclass(frozen=True)
class CaseVerdict:
    """One case's verdict: its test, its median seconds per solve (or call) on each side by the test's
    clock, and the instances left out because the commits built them differently."""

    case: str
    test: PairedTest
    old_seconds: float
    new_seconds: float
    left_out: int = 0


@dataclass
class ABComparison:
    """Every case of a timing session judged, and what stands in the way of any verdict.

    Attributes
    ----------
    old, new : str
        The versions compared (as named on the command line).
    problems : list of str
        Answers the independent check rejected, exact solvers that disagreed and what could not be measured:
        each a failure of the comparison, whatever the times say.
    """

    old: str
    new: str
    threshold: float
    alpha: float
    cases: list[CaseVerdict]
    measurement: Measurement
    problems: list[str] = field(default_factory=list)

    def slower(self, above: float) -> list[CaseVerdict]:
        """Cases judged slower whose ratio exceeds ``above``."""
        return [case for case in self.cases if case.test.verdict == "slower" and case.test.ratio > above]


def compare_measurement(
    measurement: Measurement, *, alpha: float = 0.01, threshold: float = 0.1
) -> ABComparison:
    """Judge every case of a two-version `harness.Measurement` (module notes).

    Parameters
    ----------
    measurement : Measurement
        With exactly two versions: the first is the old side.
    alpha : float in (0, 1)
        Level of the Benjamini-Hochberg adjusted tests and of the intervals.
    threshold : float >= 0
        Least relative change that counts (`reports._paired.judge`).

    Returns
    -------
    ABComparison
    """
    old, new = (version.name for version in measurement.versions)
    samples = measurement.samples
    digests = _differing(measurement.instances, old, new)
    rows = samples[samples["valid"].astype(bool)]
    tests, facts = [], []
    for (case, cold), of_case in rows.groupby(["case", "cold"], sort=True):
        name = f"{case} (first call)" if cold else case
        kept = of_case[~of_case.set_index(["group", "instance"]).index.isin(digests)]
        left_out = of_case.loc[~of_case.index.isin(kept.index), ["group", "instance"]].drop_duplicates()
        units, clock, unit = unit_values(kept, old, new)
        tests.append(paired_test(units, samples=len(kept), clock=clock, unit=unit, alpha=alpha))
        seconds = kept.assign(seconds=per_solve(kept, clock)).groupby("version")["seconds"].median()
        facts.append((name, seconds.get(old, math.nan), seconds.get(new, math.nan), len(left_out)))
    judged = judge(tests, alpha=alpha, threshold=threshold)
    cases = [
        CaseVerdict(name, test, float(before), float(after), left)
        for (name, before, after, left), test in zip(facts, judged, strict=True)
    ]
    return ABComparison(old, new, threshold, alpha, cases, measurement, _problems(measurement, digests))


def _differing(instances: pd.DataFrame, old: str, new: str) -> set[tuple[str, int]]:
    """(group, instance) whose digests differ between the two versions."""
    if instances.empty:
        return set()
    table = instances.pivot_table(
        index=["group", "instance"], columns="version", values="digest", aggfunc="first"
    )
    if old not in table or new not in table:
        return set()
    return set(table.index[table[old] != table[new]])


def _problems(measurement: Measurement, differing: set[tuple[str, int]]) -> list[str]:
    found = list(measurement.errors)
    answers = measurement.answers
    if not answers.empty:
        for row in answers[answers["problem"] != ""].itertuples(index=False):
            found.append(f"{row.version}: {row.group} expression {row.instance}, {row.solver}: {row.problem}")
    if differing:
        listed = ", ".join(f"{group} {instance}" for group, instance in sorted(differing)[:5])
        more = f" and {len(differing) - 5} more" if len(differing) > 5 else ""
        found.append(
            f"{len(differing)} instances differ between the commits and are not timed against each other: "
            f"{listed}{more}"
        )
    return found


def comparison_table(comparison: ABComparison, *, fail_above: float | None, warn_above: float) -> Table:
    """One row per case: median seconds per solve on each side, the ratio with its interval, the verdict
    and what it rests on; failing rows bold red, warned ones yellow."""
    measurement = comparison.measurement
    table = Table(
        title=f"{comparison.old} -> {comparison.new}: {measurement.suite.name} suite, "
        f"{measurement.rounds} rounds, {measurement.seconds:.0f} s",
        caption=f"CPU seconds per solve (or transfer call), each case against itself on the same instances; "
        f"slower or faster: Benjamini-Hochberg q < {comparison.alpha:g} over the {len(comparison.cases)} "
        f"cases and a ratio beyond {1 + comparison.threshold:.2f}; same: the {1 - comparison.alpha:.0%} "
        f"interval within it"
        + (f"; fails above x{fail_above:g}" if fail_above else "")
        + f"; warns above x{warn_above:g}",
    )
    for column in ("case", comparison.old, comparison.new, "new/old", "verdict", "rests on"):
        justify = "right" if column in (comparison.old, comparison.new, "new/old") else "left"
        table.add_column(escape(column), justify=justify)
    for case in comparison.cases:
        test = case.test
        style = _STYLES[test.verdict]
        if test.verdict == "slower" and test.ratio > warn_above:
            style = "bold yellow"
        if fail_above is not None and test.verdict == "slower" and test.ratio > fail_above:
            style = "bold red"
        left = f"; {case.left_out} instances differ" if case.left_out else ""
        table.add_row(
            escape(case.case),
            _seconds(case.old_seconds),
            _seconds(case.new_seconds),
            "" if math.isnan(test.ratio) else f"{test.ratio:.3f}",
            test.verdict,
            escape(test.describe() + left),
            style=style,
        )
    return table


def _seconds(value: float) -> str:
    if math.isnan(value):
        return "-"
    if value < 1e-3:
        return f"{value * 1e6:.1f} µs"
    if value < 1.0:
        return f"{value * 1e3:.2f} ms"
    return f"{value:.3g} s"
