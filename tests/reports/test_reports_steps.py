"""`reports._steps`: steps across commits, each commit a ratio to the anchor measured beside it."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from reports._steps import ANCHOR, COMMIT, commit_series, detect_steps

COMMITS = [f"{i:040x}" for i in range(1, 31)]
NEIGHBOURS = dict(zip(COMMITS[1:], COMMITS[:-1], strict=True))


def history(factors: list[float], *, drift: float = 0.3, noise: float = 0.03, seed: int = 0) -> pd.DataFrame:
    """Store samples of one case over ``COMMITS``: each commit's time ``factors[i]`` times the anchor's, the
    machine's speed drifting by up to ``drift`` from round to round (alike on both sides of a round), each
    sample off by ``noise`` (log sd)."""
    rng = np.random.default_rng(seed)
    rows = []
    for commit, factor in zip(COMMITS, factors, strict=True):
        for round_ in range(3):
            speed = math.exp(rng.uniform(-drift, drift))
            for instance in range(8):
                for version, scale in ((ANCHOR, 1.0), (COMMIT, factor)):
                    for _ in range(3):
                        seconds = 1e-3 * (1 + instance) * scale * speed * math.exp(rng.normal(0.0, noise))
                        rows.append(
                            {"commit": commit, "session": commit[:8], "round": round_, "instance": instance,
                             "version": version, "case": "arkit52/big-eyes/cpsat", "cold": False,
                             "valid": True, "number": 10, "thread": 10 * seconds, "process": 10 * seconds,
                             "children": 0.0}
                        )  # fmt: skip
    return pd.DataFrame(rows)


def test_a_step_of_a_drifting_machine_is_named_at_its_commit():
    series = commit_series(history([1.0] * 17 + [1.3] * 13), COMMITS)
    assert list(series["commit"]) == COMMITS
    assert series["value"].iloc[:17].between(0.95, 1.05).all()  # the drift cancels against the anchor
    (step,) = detect_steps(series, neighbours=NEIGHBOURS)
    assert step.commit == COMMITS[17] and step.previous == COMMITS[16] and step.exact
    assert step.ratio == pytest.approx(1.3, rel=0.03)
    assert step.low < 1.3 < step.high and step.p < 0.01


def test_no_step_in_unchanged_commits():
    for seed in range(5):
        assert (
            detect_steps(commit_series(history([1.0] * 30, seed=seed), COMMITS), neighbours=NEIGHBOURS) == []
        )


def test_a_step_between_two_measured_commits_is_not_named_until_bisected():
    every_third = COMMITS[::3]
    samples = history([1.0] * 17 + [1.3] * 13)
    series = commit_series(samples, every_third)
    (step,) = detect_steps(series, neighbours=NEIGHBOURS)
    assert (step.previous, step.commit) == (COMMITS[15], COMMITS[18]) and not step.exact


def test_a_step_smaller_than_the_threshold_is_not_reported():
    series = commit_series(history([1.0] * 17 + [1.05] * 13, noise=0.005, drift=0.0), COMMITS)
    assert detect_steps(series, neighbours=NEIGHBOURS, threshold=0.1) == []
    (step,) = detect_steps(series, neighbours=NEIGHBOURS, threshold=0.02)
    assert step.commit == COMMITS[17]


def test_invalid_samples_and_unknown_commits_are_left_out():
    samples = history([1.0] * 30)
    samples.loc[samples["commit"] == COMMITS[3], "valid"] = False
    series = commit_series(samples, COMMITS[:10])
    assert list(series["commit"]) == [c for c in COMMITS[:10] if c != COMMITS[3]]
