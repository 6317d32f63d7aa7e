"""Steps in a case's time across commits: where it rose or fell, by how much, and how sure that is.

A history measured one commit after another is measured at different moments, and a shared machine's
speed drifts between them by more than the steps worth finding (measured here: an untouched solver's CPU
time per solve moved by 40 % over ten minutes of other jobs). So every commit is measured side by side with
one *anchor* commit, the same for the whole history (`reports._tracking`), sample by sample as
``harness compare --commits`` does, and a commit's figure of a case is its time as a ratio to the same
case at the anchor, measured in the same moments: each solver against itself at the anchor, never against
another solver. Per round of fresh processes, the mean over the suite's instances of the log ratio of the
two sides' median CPU seconds per solve (or transfer call) is one replicate; a commit's figure is the
geometric mean of its replicates, with their standard error (`commit_series`).

Over a case's commits, in git's first-parent order, the step detection is asv's
(`asv.step_detect.detect_steps`: a piecewise-constant fit with an L1 cost and a penalty chosen by an
information criterion, each commit weighted by the inverse square of its figure's standard error), on the
logarithms of the figures. A boundary between two fitted levels is a step only when it is more than
``threshold`` apart (relative) and Welch's t-test on the two levels' replicates says the levels differ
(``p < alpha``); its interval is Welch's t-interval of the ratio of the levels.

A step's first commit is only named for sure when the commit before it was measured too: with ``--every
N`` the change may lie anywhere in the commits between the two measured ones, and ``--bisect`` measures
commits in between until the two are neighbours (`Step.exact`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd
from scipy import stats

from reports._paired import clock_of, per_solve


@dataclass(frozen=True)
class Step:
    """One step of one case.

    Attributes
    ----------
    case : str
    commit : str
        The first measured commit of the new level.
    previous : str
        The last measured commit of the old level.
    ratio : float
        New level over old level (geometric means of the commits' ratios to the anchor).
    low, high : float
        Welch's ``1 - alpha`` t-interval of the ratio, from the two levels' replicates.
    p : float
        Welch's p-value.
    exact : bool
        Whether ``previous`` is the commit right before ``commit`` (its first parent): the step's commit
        is then named.
    """

    case: str
    commit: str
    previous: str
    ratio: float
    low: float
    high: float
    p: float
    exact: bool


#: How a store names the two sides of a commit's measurement (`reports._tracking`).
ANCHOR, COMMIT = "anchor", "commit"


def commit_series(samples: pd.DataFrame, order: list[str]) -> pd.DataFrame:
    """Each case's figure per commit (module notes), in the commits' ``order``.

    Parameters
    ----------
    samples : DataFrame
        A store's samples of one machine, suite and anchor (`harness.TrackStore.read`), both sides (the
        ``version`` column: `ANCHOR` or `COMMIT`); invalid samples are left out.
    order : list of str
        Commit ids, oldest first; samples of other commits are left out.

    Returns
    -------
    DataFrame with ``case``, ``commit``, ``position`` (in ``order``), ``value`` (the ratio to the anchor),
    ``log_se`` (the standard error of its logarithm over the replicates; NaN with one), ``seconds`` (the
    commit's own geometric mean over instances of the median seconds per solve), ``replicates``, ``clock``
    and ``replicates_log`` (the replicates' log ratios, a list).
    """
    position = {commit: index for index, commit in enumerate(order)}
    rows = samples[samples["valid"].astype(bool) & samples["commit"].isin(position)]
    found = []
    for (case, cold), of_case in rows.groupby(["case", "cold"], sort=True):
        name = f"{case} (first call)" if cold else case
        clock = clock_of(of_case)
        logs = np.log(per_solve(of_case, clock).clip(lower=np.finfo(float).tiny))
        medians = of_case.assign(log=logs).groupby(["commit", "session", "round", "instance", "version"])[
            "log"
        ]
        sides = medians.median().unstack("version")
        if ANCHOR not in sides or COMMIT not in sides:
            continue
        paired = sides.dropna(subset=[ANCHOR, COMMIT])
        ratios = (paired[COMMIT] - paired[ANCHOR]).groupby(level=["commit", "session", "round"]).mean()
        own = paired[COMMIT].groupby(level="commit").mean()
        for commit, replicates in ratios.groupby(level="commit"):
            values = replicates.to_numpy(float)
            spread = float(np.std(values, ddof=1)) if len(values) > 1 else math.nan
            found.append(
                {
                    "case": name,
                    "commit": commit,
                    "position": position[commit],
                    "value": math.exp(float(values.mean())),
                    "log_se": spread / math.sqrt(len(values)),
                    "seconds": math.exp(float(own[commit])),
                    "replicates": len(values),
                    "clock": clock,
                    "replicates_log": list(values),
                }
            )
    columns = [
        "case",
        "commit",
        "position",
        "value",
        "log_se",
        "seconds",
        "replicates",
        "clock",
        "replicates_log",
    ]
    frame = pd.DataFrame(found, columns=columns)
    return frame.sort_values(["case", "position"], kind="stable").reset_index(drop=True)


def detect_steps(
    series: pd.DataFrame,
    *,
    neighbours: dict[str, str],
    threshold: float = 0.1,
    alpha: float = 0.01,
) -> list[Step]:
    """The steps of every case of ``series`` (`commit_series`).

    Parameters
    ----------
    series : DataFrame
    neighbours : dict
        Commit -> the commit right before it (its first parent), for `Step.exact`.
    threshold : float
        Least relative size of a step.
    alpha : float
        Level of Welch's test between two levels, and of the intervals.

    Returns
    -------
    list of Step, by case and then commit position.
    """
    from asv.step_detect import detect_steps as fitted_levels

    found = []
    for case, rows in series.groupby("case", sort=True):
        rows = rows.sort_values("position")
        logs = np.log(rows["value"].to_numpy(float))
        se = rows["log_se"].to_numpy(float)
        finite = se[np.isfinite(se) & (se > 0)]
        floor = float(np.median(finite)) if len(finite) else 1.0
        weights = 1.0 / np.square(np.where(np.isfinite(se) & (se > 0), se, floor))
        levels = fitted_levels(list(logs), list(weights))
        commits = rows["commit"].tolist()
        rounds = rows["replicates_log"].tolist()
        for (left, right, *_), (start, end, *_) in zip(levels, levels[1:], strict=False):
            step = _step(case, commits, logs, rounds, (left, right), (start, end), alpha)
            if step is not None and abs(math.log(step.ratio)) > math.log1p(threshold):
                found.append(replace(step, exact=neighbours.get(step.commit) == step.previous))
    return found


def _step(
    case: str,
    commits: list[str],
    logs: np.ndarray,
    rounds: list[list[float]],
    before: tuple[int, int],
    after: tuple[int, int],
    alpha: float,
) -> Step | None:
    """The step between two fitted levels, when Welch's test on their replicates says they differ."""
    old = np.concatenate([rounds[i] for i in range(*before)])
    new = np.concatenate([rounds[i] for i in range(*after)])
    if len(old) < 2 or len(new) < 2:
        return None
    test = stats.ttest_ind(new, old, equal_var=False)
    if not test.pvalue < alpha:
        return None
    shift = float(logs[after[0] : after[1]].mean() - logs[before[0] : before[1]].mean())
    interval = test.confidence_interval(confidence_level=1.0 - alpha)
    return Step(
        case,
        commits[after[0]],
        commits[before[1] - 1],
        math.exp(shift),
        math.exp(float(interval.low)),
        math.exp(float(interval.high)),
        float(test.pvalue),
        False,
    )
