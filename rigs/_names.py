"""Left/right blendshape names: which side a name is on and which names are mirror twins.

Rigs name the two halves of a mirror pair (Carrigan et al. 2020, sec. 4.4.1) by a side token: a suffix
``_L``/``_R`` (FACS-style, ARKit's ``browDown_L``), ``.L``/``.R`` (Blender), a prefix ``L_``/``R_``, a word
``Left``/``Right`` (ARKit's ``eyeBlinkLeft``), ``left``/``right`` or ``_Lf``/``_Rt``. The geometric detector
does not read names; these helpers let callers cross-check it against them (`compare_name_pairs`).
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence

_SEPARATOR = r"_.\-\s"
#: Side tokens as (left, right) spellings; each matches only as a whole token: a single letter or an
#: abbreviation between separators (or the ends of the name), a word at a camel-case boundary.
_TOKENS: tuple[tuple[str, str, str], ...] = (
    # (left, right, pattern with {token} standing for either spelling)
    ("L", "R", rf"(?<![^{_SEPARATOR}]){{token}}(?![^{_SEPARATOR}])"),
    ("l", "r", rf"(?<![^{_SEPARATOR}]){{token}}(?![^{_SEPARATOR}])"),
    ("Lf", "Rt", rf"(?<![^{_SEPARATOR}]){{token}}(?![^{_SEPARATOR}])"),
    ("Left", "Right", r"(?<![A-Z]){token}(?![a-z])"),
    ("left", "right", r"(?<![A-Za-z]){token}(?![a-z])"),
    ("LEFT", "RIGHT", r"(?<![A-Za-z]){token}(?![A-Za-z])"),
)
_PATTERNS = tuple(
    (
        re.compile(pattern.format(token=re.escape(left))),
        re.compile(pattern.format(token=re.escape(right))),
        left,
        right,
    )
    for left, right, pattern in _TOKENS
)
#: Any left token, any right token: one alternation per side (a name has a side's token when one of the
#: side's patterns matches somewhere in it).
_ANY_LEFT, _ANY_RIGHT = (
    re.compile("|".join(f"(?:{patterns[side].pattern})" for patterns in _PATTERNS)) for side in (0, 1)
)


def side_of(name: str) -> str | None:
    """The side a blendshape name is on by its side tokens: ``"L"``, ``"R"`` or None.

    None when the name has no side token, or tokens of both sides (``"L_to_R"``).

    Examples
    --------
    >>> side_of("eyeBlinkLeft"), side_of("browDown_R"), side_of("jawOpen"), side_of("bright")
    ('L', 'R', None, None)
    """
    left, right = _ANY_LEFT.search(name) is not None, _ANY_RIGHT.search(name) is not None
    return ("L" if left else "R") if left != right else None


def mirror_name_pairs(names: Iterable[str]) -> list[tuple[str, str]]:
    """Pairs of names that differ only by their side tokens, left name first, sorted by it.

    A left name's twin swaps every side token for the other side's spelling of the same convention
    (``_L`` -> ``_R``, ``Left`` -> ``Right``, ``l_`` -> ``r_``); a name whose twin is not among
    ``names`` is not listed.

    Examples
    --------
    >>> mirror_name_pairs(["eyeBlinkRight", "jawOpen", "eyeBlinkLeft", "brow.L", "brow.R", "cheek_L"])
    [('brow.L', 'brow.R'), ('eyeBlinkLeft', 'eyeBlinkRight')]
    """
    return _twins(_sides(names))


def _sides(names: Iterable[str]) -> dict[str, str | None]:
    """`side_of` each distinct name."""
    return {name: side_of(name) for name in set(names)}


def _twins(sides: dict[str, str | None]) -> list[tuple[str, str]]:
    """`mirror_name_pairs` of the names whose sides are ``sides``."""
    pairs = []
    for name, side in sides.items():
        if side == "L":
            twin = _swapped(name)
            if sides.get(twin) == "R":
                pairs.append((name, twin))
    return sorted(pairs)


def compare_name_pairs(
    geometric: Iterable[tuple[str, str]], names: Sequence[str]
) -> tuple[list[tuple[str, str]], list[tuple[str, str]]]:
    """Cross-check geometric symmetry pairs against the names' left/right twins.

    Parameters
    ----------
    geometric : iterable of (str, str)
        Pairs found from the geometry (e.g. `packing.find_symmetry_pairs`), in any order.
    names : sequence of str
        All blendshape names of the rig.

    Returns
    -------
    contradicting : list of (str, str)
        Geometric pairs whose two names both carry a side token but are not name twins (e.g.
        ``("eyeBlink_L", "cheekPuff_R")``), in the order given.
    missed : list of (str, str)
        Name twins (`mirror_name_pairs`) that geometry did not pair, left name first, sorted.

    Raises
    ------
    ValueError
        If a geometric pair is not two names, or names a shape not in ``names``.

    Examples
    --------
    >>> names = ["eyeBlink_L", "eyeBlink_R", "brow_L", "brow_R", "jawOpen"]
    >>> compare_name_pairs([("eyeBlink_R", "eyeBlink_L"), ("brow_L", "jawOpen")], names)
    ([], [('brow_L', 'brow_R')])
    """
    known = set(names)
    pairs = [tuple(pair) for pair in geometric]
    for pair in pairs:
        if len(pair) != 2 or not all(isinstance(name, str) for name in pair):
            raise ValueError(f"compare_name_pairs: a pair must be two shape names, got {pair!r}")
        unknown = [name for name in pair if name not in known]
        if unknown:
            raise ValueError(f"compare_name_pairs: pair {pair!r} names unknown shape {unknown[0]!r}")
    sides = _sides(names)
    twins = _twins(sides)
    twin_sets = {frozenset(pair) for pair in twins}
    found = {frozenset(pair) for pair in pairs}
    contradicting = [
        pair
        for pair in pairs
        if sides[pair[0]] is not None and sides[pair[1]] is not None and frozenset(pair) not in twin_sets
    ]
    missed = [pair for pair in twins if frozenset(pair) not in found]
    return contradicting, missed


def _swapped(name: str) -> str:
    """The name with every side token replaced by the other side's spelling of the same convention."""
    for left, right, left_token, right_token in _PATTERNS:
        if left.search(name) or right.search(name):
            marked = left.sub("\0", name)
            marked = right.sub(left_token, marked)
            name = marked.replace("\0", right_token)
    return name
