"""The one rule every row of the claims table follows (`reports._claims`).

The unit of evidence is a face: one rig generated (or read) with one seed, ``(rig_seed, rig)``. The points
of one face (its warps, its J values, the expressions of one sequence) share that face and its sequence, so
they are not independent; each claim first reduces a face's points to one *effect* (a median relative
difference, a share, an excess), then judges the mean effect over faces by its two-sided Student t
interval at `CONFIDENCE` against the *region* the claim names (below -1 %, at most 2 %, within 63-98 %):

========== ===========================================================================================
verdict    when
========== ===========================================================================================
held       the interval lies wholly inside the region
not held   the interval lies wholly outside it
inconclusive the interval crosses the region's edge, or there is one face only (no interval)
========== ===========================================================================================

A point where the two sides tie is a difference of 0, no direction. More faces only narrow the interval, so
adding seeds makes a verdict firmer, never harder to pass for another reason than the evidence; a claim
whose true effect sits on the region's edge stays inconclusive, and two sets of seeds may then disagree.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import pandas as pd
from scipy import stats

#: The unit of evidence: one face (a rig and the seed it was generated or read with).
UNIT: tuple[str, ...] = ("rig_seed", "rig")
#: Confidence of the interval of a claim's mean effect over faces.
CONFIDENCE = 0.95

HELD, NOT_HELD, INCONCLUSIVE, NOT_MEASURED = "held", "not held", "inconclusive", "not measured"


@dataclass(frozen=True)
class Region:
    """The effects a claim names: ``low <= effect <= high`` (either side open when infinite)."""

    low: float = -math.inf
    high: float = math.inf

    def text(self, shown: Callable[[float], str]) -> str:
        """``at most -1%``, ``at least 63%`` or ``63%-98%``, the bounds written by ``shown``."""
        if math.isinf(self.low):
            return f"at most {shown(self.high)}"
        if math.isinf(self.high):
            return f"at least {shown(self.low)}"
        return f"{shown(self.low)} to {shown(self.high)}"


@dataclass(frozen=True)
class Judgement:
    """A claim's verdict with the mean effect over faces and its interval (NaN bounds for one face)."""

    verdict: str
    mean: float
    low: float
    high: float
    faces: int
    by_seed: pd.Series

    def text(self, region: Region, shown: Callable[[float], str] = "{:+.1%}".format) -> str:
        """``mean over 4 faces -9.1% (95% interval -10.0% to -8.2%; claimed: at most -1.0%); per seed 0:
        -9.1%, 1: ...``."""
        faces = f"{self.faces} face{'s' if self.faces != 1 else ''}"
        if math.isnan(self.low):
            spread = f"one face: no interval; run --seeds 0-4; claimed: {region.text(shown)}"
        else:
            spread = (
                f"{CONFIDENCE:.0%} interval {shown(self.low)} to {shown(self.high)}; "
                f"claimed: {region.text(shown)}"
            )
        seeds = ", ".join(f"{seed}: {shown(value)}" for seed, value in self.by_seed.items())
        return f"mean over {faces} {shown(self.mean)} ({spread}); per seed {seeds}"


def judge(effects: pd.Series, region: Region) -> Judgement:
    """Judge one effect per face against ``region`` by the module's rule.

    Parameters
    ----------
    effects : Series
        One effect per face, indexed by `UNIT` (NaN effects are left out).
    region : Region
        The effects the claim names.

    Returns
    -------
    Judgement
        ``held``, ``not held`` or ``inconclusive``, with the mean, its interval and the mean per seed.
    """
    effects = effects.dropna().astype(float)
    mean, faces = float(effects.mean()), len(effects)
    by_seed = effects.groupby(level=UNIT[0]).mean()
    if faces < 2:
        return Judgement(INCONCLUSIVE, mean, math.nan, math.nan, faces, by_seed)
    error = float(stats.sem(effects.to_numpy()))
    if error > 0:
        low, high = (float(bound) for bound in stats.t.interval(CONFIDENCE, faces - 1, mean, error))
    else:
        low = high = mean  # every face measured the same effect
    if region.low <= low and high <= region.high:
        verdict = HELD
    elif high < region.low or low > region.high:
        verdict = NOT_HELD
    else:
        verdict = INCONCLUSIVE
    return Judgement(verdict, mean, low, high, faces, by_seed)
