"""Artist constraints: shape pairs an expression must hold together or keep apart.

Geometry cannot know every pose an actor can hold: ``eyeLookOut_L`` with ``eyeLookOut_R`` is a divergent gaze
no actor can pose, while ``eyeLookOut_L`` with ``eyeLookIn_R`` is a plain gaze to the left. These pairs are
data given by the user. A *together* pair is forced into one item like a symmetry pair (eq. 3d, sec. 4.4); an
*apart* pair becomes one more conflict row ``w_a + w_b <= 1`` (the same form as eq. 3b after presolve).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any

from registry import HarnessError

if TYPE_CHECKING:
    from rigs import Rig

#: The keys of a constraints JSON file.
CONSTRAINT_KINDS = ("together", "apart")

Pair = tuple[str, str]


def parse_pair(text: str) -> Pair:
    """``"A,B"`` -> ``("A", "B")``: two distinct shape names separated by a comma (spaces trimmed).

    Raises
    ------
    ValueError
        For anything else, quoting the text.
    """
    parts = [part.strip() for part in str(text).split(",")]
    if len(parts) != 2 or not all(parts):
        raise HarnessError(f"{text!r} is not a pair of shape names 'A,B'")
    if parts[0] == parts[1]:
        raise HarnessError(f"{text!r} pairs a shape with itself")
    return parts[0], parts[1]


def as_pairs(value: Iterable[Any], what: str) -> tuple[Pair, ...]:
    """Normalise pairs given as ``"A,B"`` strings or two-element sequences of names.

    Raises
    ------
    ValueError
        Naming ``what`` (e.g. ``together``) and the entry at fault.
    """
    if isinstance(value, str | bytes):
        raise HarnessError(f"{what} must be a list of shape pairs, got the string {value!r}")
    pairs = []
    try:
        entries = list(value)
    except TypeError:
        raise HarnessError(f"{what} must be a list of shape pairs, got {value!r}") from None
    for entry in entries:
        if isinstance(entry, str):
            pair = parse_pair(entry)
        elif isinstance(entry, Sequence) and len(entry) == 2 and all(isinstance(n, str) for n in entry):
            pair = parse_pair(",".join(entry))
        else:
            raise HarnessError(f"{what}: entry {entry!r} is not a pair of shape names")
        pairs.append(pair)
    return tuple(dict.fromkeys(pairs))


#: Largest constraints file read: a million pairs of long shape names.
MAX_CONSTRAINTS_BYTES = 64 * 2**20


def read_constraints(path: str | PathLike[str]) -> dict[str, tuple[Pair, ...]]:
    """Artist constraints from a JSON file ``{"together": [["A", "B"], ...], "apart": [...]}``.

    Either key may be missing; no other key is allowed.

    Raises
    ------
    ValueError
        Naming the file and what is wrong (missing, not a regular file, larger than
        `MAX_CONSTRAINTS_BYTES`, not JSON or nested too deeply, unknown key, an entry that is not a pair).
    """
    import rigs

    path = Path(path)
    document = rigs.read_json(path, limit=MAX_CONSTRAINTS_BYTES, what="constraints file")
    if not isinstance(document, Mapping):
        raise HarnessError(f"{path}: constraints JSON must be an object with 'together' and/or 'apart'")
    unknown = sorted(set(document) - set(CONSTRAINT_KINDS))
    if unknown:
        raise HarnessError(
            f"{path}: unknown key {', '.join(map(repr, unknown))}; expected 'together', 'apart'"
        )
    try:
        return {kind: as_pairs(document.get(kind, ()), kind) for kind in CONSTRAINT_KINDS}
    except ValueError as error:
        raise HarnessError(f"{path}: {error}") from None


def resolve_pairs(rig: Rig, pairs: Iterable[Pair], what: str) -> list[tuple[int, int]]:
    """Shape indices of named pairs, lower index first.

    Raises
    ------
    ValueError
        For a name the rig lacks (with close matches), naming ``what``.
    """
    resolved = []
    for a, b in pairs:
        try:
            first, second = rig.index(a), rig.index(b)
        except ValueError as error:  # RigError names the rig, the shape and close matches
            raise HarnessError(f"{what} {a},{b}: {error}") from None
        resolved.append((min(first, second), max(first, second)))
    return resolved


def check_consistent(rig: Rig, together: list[tuple[int, int]], apart: list[tuple[int, int]]) -> None:
    """A pair both together and apart, or a shape in two together pairs, is a contradiction.

    Raises
    ------
    ValueError
        Naming the shapes.
    """
    names = rig.names
    both = sorted(set(together) & set(apart))
    if both:
        a, b = both[0]
        raise HarnessError(f"{names[a]},{names[b]} is both a together and an apart pair")
    seen: dict[int, int] = {}
    for a, b in together:
        for shape, other in ((a, b), (b, a)):
            if shape in seen and seen[shape] != other:
                raise HarnessError(
                    f"{names[shape]} is in two together pairs ({names[seen[shape]]} and {names[other]}); "
                    "an item holds at most two shapes"
                )
            seen[shape] = other
