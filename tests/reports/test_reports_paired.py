"""`reports._paired`: each case judged against itself on paired units, with an interval and four verdicts."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from reports._paired import MIN_UNITS, clock_of, judge, paired_test, per_solve, unit_values


def _test(logs: list[float], alpha: float = 0.01):
    units = pd.DataFrame({"old": np.ones(len(logs)), "new": np.exp(logs)})
    return paired_test(units, samples=2 * len(logs), clock="thread", unit="instances", alpha=alpha)


def test_the_estimate_is_the_geometric_mean_of_the_units_ratios_with_its_t_interval():
    logs = [0.1, 0.2, 0.3, 0.2, 0.25, 0.15]
    test = _test(logs)
    assert test.ratio == pytest.approx(math.exp(np.mean(logs)))
    half = 4.032 * np.std(logs, ddof=1) / math.sqrt(6)  # t(0.995, 5)
    assert test.low == pytest.approx(math.exp(np.mean(logs) - half), rel=1e-3)
    assert test.high == pytest.approx(math.exp(np.mean(logs) + half), rel=1e-3)


@pytest.mark.parametrize(
    ("logs", "verdict"),
    [
        ([math.log(1.3) + e for e in (0.01, -0.01, 0.02, 0.0, -0.02, 0.01)], "slower"),
        ([-math.log(1.3) + e for e in (0.01, -0.01, 0.02, 0.0, -0.02, 0.01)], "faster"),
        ([e for e in (0.01, -0.01, 0.02, 0.0, -0.02, 0.01)], "same"),
        ([0.4, -0.3, 0.2, -0.5, 0.6, -0.1], "inconclusive"),  # too wide to say
        ([math.log(1.05) + e for e in (0.001, -0.001, 0.0, 0.002, -0.002, 0.001)], "same"),  # real, but small
        ([0.1, 0.2], "untested"),
    ],
)
def test_verdicts(logs, verdict):
    (judged,) = judge([_test(logs)], alpha=0.01, threshold=0.1)
    assert judged.verdict == verdict


def test_an_inconclusive_case_says_what_it_could_have_seen():
    (judged,) = judge([_test([0.4, -0.3, 0.2, -0.5, 0.6, -0.1])], alpha=0.01, threshold=0.1)
    assert judged.detectable > 1.1
    assert f"could only see x{judged.detectable:.3g} or more" in judged.describe()
    (small,) = judge([_test([0.01, -0.01, 0.0, 0.01, -0.01, 0.0])], alpha=0.01, threshold=0.1)
    assert small.detectable == pytest.approx(1.1)  # the spread is not what limits it: the threshold is


def test_identical_units_are_the_same_without_a_warning():
    with np.errstate(all="raise"):
        (judged,) = judge([_test([0.0] * 8)], alpha=0.01, threshold=0.1)
    assert judged.verdict == "same" and judged.p == 1.0 and (judged.low, judged.high) == (1.0, 1.0)


def _samples(version: str, instances: int, rounds: int, repeat: int, scale: float, seed: int) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    rows = [
        {"version": version, "instance": i, "round": r, "number": 10, "thread": 0.01 * scale * (1 + i) *
         math.exp(rng.normal(0, 0.02)), "process": 0.0, "children": 0.0}
        for i in range(instances) for r in range(rounds) for _ in range(repeat)
    ]  # fmt: skip
    frame = pd.DataFrame(rows)
    frame["process"] = frame["thread"]
    return frame


@pytest.mark.parametrize(
    ("instances", "rounds", "unit", "count"),
    [(8, 2, "instances", 8), (3, 2, "instance rounds", 6), (1, 2, "sample pairs", 6)],
)
def test_a_case_of_few_instances_takes_finer_units(instances, rounds, unit, count):
    both = pd.concat(
        [_samples("a", instances, rounds, 3, 1.0, 0), _samples("b", instances, rounds, 3, 2.0, 1)]
    )
    units, clock, found = unit_values(both, "a", "b")
    assert (found, len(units)) == (unit, count) and count >= MIN_UNITS
    assert clock == "thread"
    assert np.log(units["new"] / units["old"]).mean() == pytest.approx(math.log(2.0), abs=0.05)


def test_the_clock_is_the_process_when_the_work_is_elsewhere():
    frame = _samples("a", 4, 1, 2, 1.0, 0)
    assert clock_of(frame) == "thread"
    threaded = frame.assign(process=frame["thread"] * 1.5)  # a third of the CPU outside the calling thread
    assert clock_of(threaded) == "process"
    child = frame.assign(children=frame["thread"])  # a backend that solves in a process of its own
    assert clock_of(child) == "process"
    assert per_solve(child, "process").iloc[0] == pytest.approx(2 * frame["thread"].iloc[0] / 10)
