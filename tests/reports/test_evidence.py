"""The claims' one rule (`reports._evidence`): a verdict follows from the interval of the mean effect over
faces, ties are no direction, and more of the same evidence never makes a claim harder to pass."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings, strategies as st

from reports._evidence import HELD, INCONCLUSIVE, NOT_HELD, Region, judge

BELOW = Region(high=-0.01)
VERDICTS = [HELD, INCONCLUSIVE, NOT_HELD]  # from best to worst for the claim


def faces(effects: list[float], rig: str = "female") -> pd.Series:
    index = pd.MultiIndex.from_tuples(
        [(seed, rig) for seed in range(len(effects))], names=["rig_seed", "rig"]
    )
    return pd.Series(effects, index=index, dtype=float)


def test_the_interval_is_students_t_over_faces():
    effects = [-0.05, -0.03, -0.04, -0.02]
    judged = judge(faces(effects), BELOW)
    mean, spread = np.mean(effects), np.std(effects, ddof=1) / 2
    half = 3.182446305284263 * spread  # t quantile 0.975 at 3 degrees of freedom
    assert judged.faces == 4 and judged.mean == pytest.approx(mean)
    assert (judged.low, judged.high) == pytest.approx((mean - half, mean + half))
    assert judged.verdict == HELD


@pytest.mark.parametrize(
    ("effects", "expected"),
    [
        ([-0.10, -0.09, -0.11], HELD),  # wholly below -1%
        ([0.02, 0.03, 0.01], NOT_HELD),  # wholly above it
        ([0.0, 0.0, 0.0], NOT_HELD),  # ties everywhere: no direction
        ([-0.10, 0.05, -0.02], INCONCLUSIVE),  # crosses -1%
        ([-0.5], INCONCLUSIVE),  # one face: no interval
    ],
)
def test_verdicts_follow_the_interval(effects, expected):
    assert judge(faces(effects), BELOW).verdict == expected


def test_a_two_sided_region_is_not_held_only_when_the_interval_misses_it():
    inside, crossing, outside = [0.80, 0.82, 0.81], [0.60, 0.70, 0.65], [0.99, 0.995, 1.0]
    shared = Region(0.63, 0.98)
    assert [judge(faces(e), shared).verdict for e in (inside, crossing, outside)] == [
        HELD,
        INCONCLUSIVE,
        NOT_HELD,
    ]


def test_one_face_says_how_to_get_an_interval():
    judged = judge(faces([-0.2]), BELOW)
    assert math.isnan(judged.low) and "one face: no interval; run --seeds 0-4" in judged.text(BELOW)


def test_the_text_names_the_faces_the_interval_the_region_and_each_seed():
    text = judge(faces([-0.10, -0.09, -0.11]), BELOW).text(BELOW)
    assert text.startswith("mean over 3 faces -10.0% (95% interval -12.5% to -7.5%; claimed: at most -1.0%)")
    assert text.endswith("per seed 0: -10.0%, 1: -9.0%, 2: -11.0%")


@settings(max_examples=200, deadline=None)
@given(
    st.lists(st.floats(-0.5, 0.5, allow_nan=False), min_size=2, max_size=8),
    st.integers(min_value=2, max_value=4),
)
def test_the_same_evidence_from_more_faces_never_makes_a_claim_harder_to_pass(effects, copies):
    # Seeds drawn again that measure the same effects narrow the interval around the same mean: a verdict
    # may become firmer (inconclusive -> held or not held), never move toward the other side.
    few = judge(faces(effects), BELOW).verdict
    many = judge(faces(effects * copies), BELOW).verdict
    if few != INCONCLUSIVE:
        assert many == few
