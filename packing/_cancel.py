"""Shapes whose displacements cancel when posed together (sec. 4.4.1).

Two mirror images that move the same vertices in opposite directions (jawLeft and jawRight) add up to almost
the neutral: an expression holding both carries no information and no actor can pose it. Sec. 4.4.1 keeps
such shapes out of symmetry pairs; this module finds any expression or candidate pair that still combines
them, so `harness pack` and `harness rigs info` can warn.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from itertools import combinations

import numpy as np

from rigs import Rig, mirror_name_pairs, vector_lengths

#: A pair cancels when the peak of its summed displacement is below this share of its larger part's peak.
CANCEL_RATIO = 0.5


@dataclass(frozen=True)
class Cancellation:
    """Two shapes whose summed displacement largely cancels.

    Attributes
    ----------
    shapes : (str, str)
    peak_sum : float
        ``max_n |dv_a^n + dv_b^n|``.
    peak_parts : float
        ``max(max_n |dv_a^n|, max_n |dv_b^n|)``.
    expression : int or None
        1-based expression holding both, or None for a candidate pair of the rig.
    """

    shapes: tuple[str, str]
    peak_sum: float
    peak_parts: float
    expression: int | None = None

    @property
    def ratio(self) -> float:
        """``peak_sum / peak_parts``: 1 for shapes apart or moving alike, near 0 when they cancel."""
        return self.peak_sum / self.peak_parts if self.peak_parts > 0 else 1.0

    @property
    def message(self) -> str:
        """A one-line warning for the user."""
        a, b = self.shapes
        where = f"expression {self.expression} holds" if self.expression is not None else "combining"
        return (
            f"{where} {a} and {b}, whose displacements cancel: the peak of their sum is "
            f"{self.peak_sum:.3g} against {self.peak_parts:.3g} for one alone ({self.ratio:.0%}); "
            "no actor can pose that and the scan shows almost the neutral"
        )


def find_cancellations(
    rig: Rig, groups: Iterable[Sequence[str]], *, ratio: float = CANCEL_RATIO
) -> list[Cancellation]:
    """Pairs of shapes within each group (an expression) whose summed displacement cancels.

    Parameters
    ----------
    rig : Rig
    groups : iterable of sequences of shape names
        The shapes of each expression, primary and extra examples together.
    ratio : float
        A pair cancels when ``peak_sum < ratio * peak_parts`` (default `CANCEL_RATIO`).

    Returns
    -------
    list of Cancellation, by expression (1-based position in ``groups``), then by name.

    Raises
    ------
    RigError
        For a name the rig does not have.

    Notes
    -----
    Only pairs whose displacements share a moving vertex can cancel; for those, O(N) per pair.
    """
    found, motion = [], _Motion(rig)
    for number, group in enumerate(groups, start=1):
        found += [
            replace(cancellation, expression=number)
            for cancellation in _cancelling(rig, combinations(sorted(set(group)), 2), ratio, motion)
        ]
    return found


def cancelling_twins(
    rig: Rig, pairs: Iterable[tuple[str, str]] = (), *, ratio: float = CANCEL_RATIO
) -> list[Cancellation]:
    """Left/right-named twins (`rigs.mirror_name_pairs`) and further candidate ``pairs`` that would cancel
    if combined in one expression, for `harness rigs info`."""
    candidates = dict.fromkeys([*mirror_name_pairs(rig.names), *map(tuple, pairs)])
    return _cancelling(rig, candidates, ratio)


class _Motion:
    """Per shape, computed once: peak displacement, vertices that move at all, and those that move more
    than ``still`` (1e-9 of the rig's diagonal)."""

    def __init__(self, rig: Rig) -> None:
        self.rig = rig
        self.still = 1e-9 * rig.diagonal()  # displacements below this move nothing
        self._found: dict[str, tuple[float, np.ndarray, np.ndarray]] = {}

    def __call__(self, name: str) -> tuple[float, np.ndarray, np.ndarray]:
        if name not in self._found:
            lengths = vector_lengths(self.rig.deltas[self.rig.index(name)])
            moved = np.flatnonzero(lengths)
            strong = moved[lengths[moved] > self.still]
            self._found[name] = float(lengths.max(initial=0.0)), moved, strong
        return self._found[name]


def _cancelling(
    rig: Rig, pairs: Iterable[tuple[str, str]], ratio: float, motion: _Motion | None = None
) -> list[Cancellation]:
    """The pairs whose sum cancels: a pair's sum is taken only where one of the two moves at all
    (elsewhere it is exactly zero), and only pairs that both move some vertex can cancel."""
    motion = _Motion(rig) if motion is None else motion
    found = []
    for a, b in pairs:
        (peak_a, moved_a, strong_a), (peak_b, moved_b, strong_b) = motion(a), motion(b)
        if not np.intersect1d(strong_a, strong_b, assume_unique=True).size:
            continue
        where = np.union1d(moved_a, moved_b)
        summed = rig.deltas[rig.index(a), where] + rig.deltas[rig.index(b), where]
        peak_sum = float(np.sqrt(np.einsum("ij,ij->i", summed, summed).max(initial=0.0)))
        peak_parts = max(peak_a, peak_b)
        if peak_sum < ratio * peak_parts:
            found.append(Cancellation((a, b), peak_sum, peak_parts))
    return found
