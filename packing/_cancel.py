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
    Only pairs whose displacements share a moving vertex can cancel; per group of g shapes, O(g N) to find
    them and O(N) for each.
    """
    found = []
    for number, group in enumerate(groups, start=1):
        found += [
            replace(cancellation, expression=number)
            for cancellation in _cancelling(rig, list(combinations(sorted(set(group)), 2)), ratio)
        ]
    return found


def cancelling_twins(
    rig: Rig, pairs: Iterable[tuple[str, str]] = (), *, ratio: float = CANCEL_RATIO
) -> list[Cancellation]:
    """Left/right-named twins (`rigs.mirror_name_pairs`) and further candidate ``pairs`` that would cancel
    if combined in one expression, for `harness rigs info`."""
    candidates = dict.fromkeys([*mirror_name_pairs(rig.names), *map(tuple, pairs)])
    return [found for pair in candidates for found in _cancelling(rig, [pair], ratio)]


def _cancelling(rig: Rig, pairs: Sequence[tuple[str, str]], ratio: float) -> list[Cancellation]:
    """The ``pairs`` whose sum cancels, among a few shapes (an expression's): only pairs that both move
    some vertex by more than 1e-9 of the rig's diagonal can cancel."""
    names = list(dict.fromkeys(name for pair in pairs for name in pair))
    if not names:
        return []
    row = {name: k for k, name in enumerate(names)}
    deltas = rig.deltas[rig.indices(names)]  # (g, N, 3)
    lengths = vector_lengths(deltas)
    peaks = lengths.max(axis=1, initial=0.0)
    strong = (lengths > 1e-9 * rig.diagonal()).astype(np.float32)
    shared = (strong @ strong.T) > 0  # (g, g): the two move a vertex in common
    found = []
    for a, b in pairs:
        i, j = row[a], row[b]
        if not shared[i, j]:
            continue
        peak_sum = float(vector_lengths(deltas[i] + deltas[j]).max(initial=0.0))
        peak_parts = float(max(peaks[i], peaks[j]))
        if peak_sum < ratio * peak_parts:
            found.append(Cancellation((a, b), peak_sum, peak_parts))
    return found
