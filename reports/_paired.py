"""Paired timing verdicts: each solver against itself, instance by instance, with an interval.

Two measurements of the same code differ by the machine's noise; a verdict such as "slower" is a claim
about that noise, so it rests on every sample and on a test, and says how sure it is.

- **Paired units.** Exact solvers solve identical instances in both measurements (the frozen reference
  sequence; an instance whose digest differs between them is left out and named), and the two sides of
  every sample were measured one right after the other. A case's *unit* is an instance: its time on each
  side is the median of its samples (each a calibrated run of many solves, divided by their number), and
  its log ratio ``d = log(new / old)`` is what is tested. A case with fewer than `MIN_UNITS` instances
  takes finer units, the coarsest that give enough: an instance in one round (fresh processes on both
  sides), else one pair of samples measured side by side (a transfer timed on one sequence).
- **Each solver judged against itself.** No time is divided by another solver's: a slower solver moves
  its own ratios only, and an untouched one keeps ratios near 1.
- **CPU time.** The time of a solve is the CPU time of the calling thread when the solver works in that
  thread, and of the whole process and its children when it has threads or processes of its own (CP-SAT's
  workers, CBC run as a program): a case counts as threaded when more than `THREADED_SHARE` of its CPU time
  is outside the calling thread. Wall time counts every moment the scheduler gave to another job; CPU time
  does not.
- **The estimate and its interval.** The ratio is the geometric mean of the units' ratios,
  ``exp(mean d)``, with the t-interval ``exp(mean d +- t(1 - alpha/2, n-1) sd/sqrt(n))``; the p-value is
  the one-sample t-test of ``mean d = 0`` (`scipy.stats.ttest_1samp`).
- **One family.** The p-values of one comparison are adjusted together (Benjamini-Hochberg,
  `scipy.stats.false_discovery_control`); a case is *slower* when its adjusted ``q < alpha`` and its
  ratio exceeds ``1 + threshold``, *faster* when ``q < alpha`` and its ratio is below ``1 / (1 +
  threshold)``, *same* when its whole interval lies within those two, and *inconclusive* otherwise, with
  the smallest change the comparison could have seen (`PairedTest.detectable`). A case with fewer than
  `MIN_UNITS` units is *untested*.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np
import pandas as pd
from scipy import stats

#: Fewest units for a test (5 degrees of freedom); a case with fewer instances takes finer units.
MIN_UNITS = 6

#: The units tried in turn, coarsest first, and the columns that tell them apart.
UNITS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("instances", ("instance",)),
    ("instance rounds", ("instance", "round")),
    ("sample pairs", ("instance", "round", "pair")),
)

#: Share of a case's CPU time outside the calling thread above which the process's CPU time is used.
THREADED_SHARE = 0.05

Verdict = Literal["slower", "faster", "same", "inconclusive", "untested"]


@dataclass(frozen=True)
class PairedTest:
    """The verdict on one case's time between two measurements, and what it rests on.

    Attributes
    ----------
    ratio : float
        Geometric mean over units of new / old.
    low, high : float
        The ``1 - alpha`` t-interval of ``ratio`` (NaN when untested).
    p, q : float or None
        The one-sample t-test's p-value of the log ratios, and its Benjamini-Hochberg adjustment over the
        ``family`` tests of one comparison.
    units : int
        Units the test rests on; ``unit`` says which (``instances`` or ``rounds``).
    samples : int
        Samples behind the units, both sides.
    clock : str
        What was timed: ``thread`` or ``process`` CPU time (module notes), ``cpu`` (a run's recorded CPU
        seconds) or ``wall`` (a run's seconds, when it recorded no CPU time).
    verdict : str
        ``slower``, ``faster``, ``same``, ``inconclusive`` or ``untested``.
    detectable : float or None
        The smallest slow-down (as a ratio) that this comparison's spread lets it call slower nearly
        always: ``max(1 + threshold, exp(2 t se))``, for a true change that large puts the whole interval
        above 1.
    """

    ratio: float
    low: float
    high: float
    p: float | None
    units: int
    samples: int
    clock: str = "thread"
    unit: str = "instances"
    verdict: Verdict = "untested"
    q: float | None = None
    family: int = 1
    detectable: float | None = None
    half_width: float = math.nan

    def describe(self) -> str:
        """``x1.31 [1.24, 1.38], q=2e-05 of 9, 16 instances, 960 samples, thread CPU`` and the like."""
        clock = {"thread": "thread CPU", "process": "process CPU", "cpu": "CPU"}.get(self.clock, self.clock)
        counts = f"{self.units} {self.unit}, {self.samples} samples, {clock}"
        if self.p is None:
            return f"untested: {counts} (< {MIN_UNITS} {self.unit})"
        interval = f"x{self.ratio:.3g} [{self.low:.3g}, {self.high:.3g}]"
        adjusted = "" if self.q is None else f", q={self.q:.2g} of {self.family}"
        seen = (
            f"; could only see x{self.detectable:.3g} or more"
            if self.verdict == "inconclusive" and self.detectable
            else ""
        )
        return f"{interval}{adjusted}, {counts}{seen}"


def clock_of(samples: pd.DataFrame) -> str:
    """``process`` when more than `THREADED_SHARE` of the samples' CPU (median over samples) ran outside
    the calling thread, else ``thread``."""
    total = samples["process"].astype(float) + samples["children"].astype(float).fillna(0.0).clip(lower=0)
    outside = (total - samples["thread"].astype(float)) / total.where(total > 0)
    share = float(outside.median()) if outside.notna().any() else 0.0
    return "process" if share > THREADED_SHARE else "thread"


def per_solve(samples: pd.DataFrame, clock: str) -> pd.Series:
    """Seconds of ``clock`` CPU per solve (or call) of each sample."""
    if clock == "process":
        seconds = samples["process"].astype(float) + samples["children"].astype(float).fillna(0.0).clip(
            lower=0
        )
    else:
        seconds = samples["thread"].astype(float)
    return seconds / samples["number"].astype(float)


def unit_values(samples: pd.DataFrame, old: str, new: str) -> tuple[pd.DataFrame, str, str]:
    """The paired units of one case and each side's median time in each (module notes).

    Parameters
    ----------
    samples : DataFrame
        The case's valid, warm samples of both sides (`harness._bench_session.SAMPLE_COLUMNS`), in the
        order they were taken.
    old, new : str
        The two versions' names.

    Returns
    -------
    (units, clock, unit)
        ``units`` has ``old`` and ``new`` seconds per unit (rows where both sides have one), ``clock`` the
        CPU clock used and ``unit`` the name of the units (`UNITS`).
    """
    clock = clock_of(samples)
    frame = samples.assign(seconds=per_solve(samples, clock).clip(lower=np.finfo(float).tiny))
    frame["pair"] = frame.groupby(["version", "instance", "round"]).cumcount()
    for unit, columns in UNITS:  # noqa: B007 - the last unit tried is the one returned
        table = frame.groupby(["version", *columns])["seconds"].median().unstack("version")
        for side in (old, new):
            if side not in table:
                table[side] = np.nan
        units = table[[old, new]].dropna().rename(columns={old: "old", new: "new"})
        if len(units) >= MIN_UNITS:
            break
    return units, clock, unit


def paired_test(units: pd.DataFrame, *, samples: int, clock: str, unit: str, alpha: float) -> PairedTest:
    """The estimate, interval and p-value of one case's paired units (module notes); verdicts come from
    `judge`.

    Notes
    -----
    O(n) in the units.
    """
    logs = np.log(units["new"].to_numpy(float)) - np.log(units["old"].to_numpy(float))
    n = len(logs)
    if n == 0:
        return PairedTest(math.nan, math.nan, math.nan, None, 0, samples, clock, unit)
    mean = float(logs.mean())
    if n < MIN_UNITS:
        return PairedTest(math.exp(mean), math.nan, math.nan, None, n, samples, clock, unit)
    se = float(logs.std(ddof=1)) / math.sqrt(n)
    if se <= 1e-12 * max(1.0, abs(mean)):  # identical units, up to rounding: no spread to test against
        se = 0.0
    critical = float(stats.t.ppf(1.0 - alpha / 2.0, n - 1))
    if se == 0.0:
        p = 1.0 if mean == 0.0 else 0.0
    else:
        p = float(stats.ttest_1samp(logs, 0.0).pvalue)
    half = critical * se
    return PairedTest(
        math.exp(mean),
        math.exp(mean - half),
        math.exp(mean + half),
        p,
        n,
        samples,
        clock,
        unit,
        half_width=half,
    )


def judge(tests: list[PairedTest], *, alpha: float, threshold: float) -> list[PairedTest]:
    """The verdicts of one comparison's tests, judged as one family (module notes).

    Parameters
    ----------
    tests : list of PairedTest
    alpha : float in (0, 1)
        Level of the adjusted p-values and of the intervals.
    threshold : float >= 0
        Least relative change that counts: slower beyond ``1 + threshold``, faster below its inverse, same
        when the interval lies between the two.

    Returns
    -------
    list of PairedTest
        ``tests`` in order, with ``q``, ``family``, ``verdict`` and ``detectable``.
    """
    tested = [index for index, test in enumerate(tests) if test.p is not None]
    judged = list(tests)
    if not tested:
        return judged
    adjusted = stats.false_discovery_control([tests[index].p for index in tested], method="bh")
    upper, lower = 1.0 + threshold, 1.0 / (1.0 + threshold)
    for index, q in zip(tested, adjusted, strict=True):
        test = tests[index]
        if q < alpha and test.ratio > upper:
            verdict: Verdict = "slower"
        elif q < alpha and test.ratio < lower:
            verdict = "faster"
        elif lower <= test.low and test.high <= upper:
            verdict = "same"
        else:
            verdict = "inconclusive"
        detectable = max(upper, math.exp(2.0 * test.half_width))
        judged[index] = replace(test, verdict=verdict, q=float(q), family=len(tested), detectable=detectable)
    return judged
