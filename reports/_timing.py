"""Timing samples of a run and the statistical test that judges two runs' times.

A run's times are noisy: a shared machine, a cold cache, one solve that wanders. A verdict such as "slower"
is a statistical claim, so it rests on every sample and on a test, as asv's and benchopt's do:

- **Samples.** Every solve of every repetition is kept (`timing_samples`): the seconds of one expression
  (presolve, build, solve and the rest of its step). A solve that did not finish its work (anything but
  `reports._tables.FINISHED`: a time limit, an error) is *charged at the limit* (the row's ``time_limit``),
  never counted as fast.
- **A robust reference.** Machines differ in speed, so times are divided by a reference measured in the same
  run and repetition (the grid runs repetition after repetition, so one repetition's cells share a
  moment of the machine): over the exact solvers of the same group (rig, warp, setting, repetition), the
  median on a log scale of their whole-sequence seconds (the geometric mean of the two middle solvers for
  an even count). A geometric mean of all moves by a third of its own shift when one of three solvers has
  a slow run (measured: a backend's first run 3x its others); the median does not. Taken per repetition,
  the reference's own noise is in every repetition's ratio, where the test sees it: one reference for all
  repetitions of a run shifts all its ratios alike, invisibly to the test (measured: ten pairs of runs of
  the same code on ``tiny``, whose sequences take 2 ms, gave one "faster" at p = 5e-6). With fewer than
  `MIN_REFERENCE_SOLVERS` exact solvers in a group, times stay in seconds.
- **A test on independent units.** The unit of the test is a *repetition*: a cell run again, in another
  worker process and at another moment. Solves within one cell share that moment, and measured on this
  2-core machine a whole cell moves by up to 1.9x from one repetition to the next (CP-SAT on ``female``:
  0.078-0.150 s) while its solves agree with each other; a test that took each solve as independent found
  "significant" 1.4x changes between two runs of the same code. So the two runs' per-repetition sequence
  times (ratios to the reference) are compared by Welch's t-test on their logarithms, and a case is
  *slower* or *faster* only when the test is significant (below) **and** the ratio of the median
  sequences is beyond ``1 + threshold``. With fewer than `MIN_REPETITIONS` repetitions on a side there
  is no test.

  The level is 0.01, not asv's 0.002: asv tests many samples of one process, while here the units are a
  handful of repetitions, and one repetition in five disturbed by the machine (measured: 1.6x) keeps a
  true 2x slow-down at p = 0.007. Both conditions must hold, so two runs of the same code still need a
  1 % event *and* a 25 % shift of the median to be called different.
- **One family of tests.** A comparison tests every case at once (a run of four solvers on two rigs is
  eight tests), and ten comparisons at level 0.01 are 80 chances of a false verdict: measured on this
  machine, ten A/A comparisons at 8 repetitions gave one "slower" (1.49x). So the p-values of one
  comparison are adjusted together by Benjamini-Hochberg (`scipy.stats.false_discovery_control`), and a
  verdict needs the adjusted ``q < alpha``. When no case truly changed (an A/A comparison) this bounds
  the chance of *any* verdict by ``alpha``; when some did, it bounds the expected share of false verdicts
  among them, and a true 2x change keeps its significance (its p is orders of magnitude below alpha).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd
from scipy import stats

from reports._tables import CASE_COLUMNS, FINISHED, GROUP_COLUMNS, exact_solvers, expression_rows, ok_cells

#: Fewest exact solvers whose geometric mean makes a group's reference time.
MIN_REFERENCE_SOLVERS = 2

#: Fewest repetitions on each side for a test.
MIN_REPETITIONS = 3

#: Name of the reference in figure names and captions.
REFERENCE = "median exact solver"


def timing_samples(records: pd.DataFrame) -> pd.DataFrame:
    """One row per solve of every finished cell: its charged seconds, termination and ratio to the reference.

    Parameters
    ----------
    records : DataFrame
        A run's records (`harness.read_records`).

    Returns
    -------
    DataFrame with the `GROUP_COLUMNS`, ``solver``, ``cell``, ``expression``, ``termination`` (and
    ``fallback`` when the records have it), ``seconds``
    (charged at the time limit where the solve stopped there or failed), ``reference`` (the `REFERENCE`
    of the cell's group and repetition, in seconds; NaN without one) and ``ratio`` (seconds / reference).
    """
    cells = ok_cells(records)
    rows = expression_rows(records)
    rows = rows[rows["cell"].isin(cells["cell"])].copy()
    seconds = rows["seconds"].astype(float)
    limit = pd.to_numeric(rows["time_limit"], errors="coerce").astype(float)
    charged = ~rows["termination"].astype(str).isin(FINISHED) & limit.notna()
    rows["seconds"] = np.where(charged, np.fmax(seconds, limit), seconds)
    keys = [*GROUP_COLUMNS, "solver"]
    totals = rows.groupby("cell", sort=False)["seconds"].sum()
    sequences = cells[[*keys, "cell"]].assign(total=cells["cell"].map(totals).astype(float))
    proved = set(rows.loc[rows["termination"] == "optimal", "solver"])
    proving = exact_solvers(rows["solver"], rows["termination"]) & proved  # exact, and working
    exact = sequences[sequences["solver"].isin(proving) & (sequences["total"] > 0)]
    references = (
        exact.groupby(list(GROUP_COLUMNS), dropna=False, sort=False)["total"]
        .agg(lambda totals: _log_median(totals) if len(totals) >= MIN_REFERENCE_SOLVERS else math.nan)
        .rename("reference")
        .reset_index()
    )
    ended = ["termination", *(["fallback"] if "fallback" in rows else [])]
    samples = rows[[*keys, "cell", "expression", *ended, "seconds"]].merge(
        references, on=list(GROUP_COLUMNS), how="left"
    )
    samples["ratio"] = samples["seconds"] / samples["reference"]
    return samples


def _log_median(totals: pd.Series) -> float:
    """The median on a log scale: the middle value, or the geometric mean of the two middle values."""
    return float(np.exp(np.median(np.log(totals.to_numpy(float)))))


def has_reference(samples: pd.DataFrame) -> bool:
    """Whether every sample of a run has a reference time to be divided by."""
    return bool(len(samples)) and bool(samples["reference"].notna().all())


@dataclass(frozen=True)
class TimingTest:
    """The verdict on one case's times between two runs, and what it rests on.

    ``ratio`` is new / old of the median sequence; ``p`` the two-sided Welch t-test p-value of the
    repetitions' log sequence times (None when not tested) and ``q`` that p adjusted over the ``family``
    tests of one comparison (`judge_times`); ``n_old`` and ``n_new`` the repetitions and ``solves`` the
    samples they hold.
    """

    ratio: float
    p: float | None
    n_old: int
    n_new: int
    solves: int
    verdict: str = "same"
    q: float | None = None
    family: int = 1

    def describe(self) -> str:
        """``p=0.0004, q=0.003 of 8 tests, 5+5 repetitions, 80 solves``, or why there was no test."""
        counts = f"{self.n_old}+{self.n_new} repetitions, {self.solves} solves"
        if self.p is None:
            return f"untested: {counts} (< {MIN_REPETITIONS} repetitions a side)"
        adjusted = "" if self.q is None else f", q={self.q:.2g} of {self.family} tests"
        return f"p={self.p:.2g}{adjusted}, {counts}"


def timing_test(old: pd.DataFrame, new: pd.DataFrame, *, value: str) -> TimingTest:
    """Test whether one case's times differ between two runs (the verdict comes from `judge_times`).

    Parameters
    ----------
    old, new : DataFrame
        The case's `timing_samples` rows in each run (``cell`` and the ``value`` column).
    value : {"ratio", "seconds"}
        Which column is compared: ratios to the reference, or seconds when a run has none.

    Returns
    -------
    TimingTest
        With ``p`` None when a side has fewer than `MIN_REPETITIONS` repetitions.

    Notes
    -----
    Welch's unequal-variances t-test (`scipy.stats.ttest_ind` with ``equal_var=False``) on the logarithms
    of the per-repetition sequence times: times are positive and their noise multiplicative, so a log scale
    makes a 2x slow-down and a 2x speed-up equally far apart. O(n) in the samples.
    """
    old_sequences, new_sequences = _sequences(old, value), _sequences(new, value)
    ratio = float(np.median(new_sequences) / np.median(old_sequences))
    counts = (len(old_sequences), len(new_sequences), len(old) + len(new))
    if min(counts[:2]) < MIN_REPETITIONS:
        return TimingTest(ratio, None, *counts)
    p = float(stats.ttest_ind(np.log(new_sequences), np.log(old_sequences), equal_var=False).pvalue)
    return TimingTest(ratio, 1.0 if math.isnan(p) else p, *counts)  # NaN: identical values on both sides


def judge_times(tests: list[TimingTest], *, alpha: float, threshold: float) -> list[TimingTest]:
    """The verdicts of one comparison's tests, judged as one family.

    Parameters
    ----------
    tests : list of TimingTest
        Every `timing_test` of one comparison (untested ones stay ``same``).
    alpha : float in (0, 1)
        Level of the Benjamini-Hochberg adjusted p-values (the false discovery rate; under no true change,
        the chance of any verdict).
    threshold : float >= 0
        Least relative change of the median sequence that counts: slower needs ``ratio > 1 + threshold``,
        faster ``ratio < 1 / (1 + threshold)``.

    Returns
    -------
    list of TimingTest
        ``tests`` in their order, each with ``q``, ``family`` and its verdict: ``slower``, ``faster`` or
        ``same``.
    """
    tested = [index for index, test in enumerate(tests) if test.p is not None]
    if not tested:
        return list(tests)
    adjusted = stats.false_discovery_control([tests[index].p for index in tested], method="bh")
    judged = list(tests)
    for index, q in zip(tested, adjusted, strict=True):
        test = tests[index]
        verdict = "same"
        if q < alpha and test.ratio > 1.0 + threshold:
            verdict = "slower"
        elif q < alpha and test.ratio < 1.0 / (1.0 + threshold):
            verdict = "faster"
        judged[index] = replace(test, verdict=verdict, q=float(q), family=len(tested))
    return judged


def _sequences(samples: pd.DataFrame, value: str) -> np.ndarray:
    """Each cell's (repetition's) summed ``value``, floored at the smallest positive float."""
    return np.fmax(samples.groupby("cell")[value].sum().to_numpy(float), np.finfo(float).tiny)


def case_samples(samples: pd.DataFrame) -> dict[tuple, pd.DataFrame]:
    """A run's samples by case (`CASE_COLUMNS` values, None for missing)."""
    if samples.empty:
        return {}
    return {
        tuple(None if pd.isna(v) else v for v in key): rows
        for key, rows in samples.groupby(list(CASE_COLUMNS), sort=True, dropna=False)
    }
