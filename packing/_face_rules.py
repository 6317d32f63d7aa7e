"""Anatomical rules that ship: pairs of facial shapes an actor cannot hold in one expression, by name.

Geometry says which shapes overlap (eq. 3b) and which mirror each other (sec. 4.4), not which poses a face can
make: the mirror pair puts ``eyeLookOut_L`` with ``eyeLookOut_R`` (wall-eyed), and nothing keeps ``tongueOut``
from ``mouthClose``. ``face_rules.toml`` beside this module lists such rules for ARKit-named rigs, each with
its reason (see the file). `match_rules` finds them in a rig's names (any case, ``_L``/``Left``/``L_`` sides,
namespaces and prefixes) and turns them into artist constraints (`packing._constraints`): together and apart
pairs, and shapes left out of the session, yielding to the artist's own constraints and saying so.
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from importlib import resources
from os import PathLike
from pathlib import Path
from typing import Any, Literal

from packing._constraints import Pair
from registry import HarnessError

#: The rules file shipped with the package.
RULES_FILE = "face_rules.toml"

Kind = Literal["together", "apart", "only_with"]
KINDS: tuple[Kind, ...] = ("together", "apart", "only_with")

#: A side written after the name: ``_L``, ``.r``, ``-Left``, ``Right`` after a lower-case letter or digit.
_SIDE_SUFFIX = re.compile(r"(?:[_.\-\s](?P<sep>left|right|l|r)|(?<=[a-z0-9])(?P<word>Left|Right))$", re.I)
#: A side written before the name: ``L_``, ``right.``.
_SIDE_PREFIX = re.compile(r"^(?P<side>left|right|l|r)[_.\-\s]", re.I)
#: Where a namespace ends (``blendShape1.``, ``head:``, ``face|``).
_NAMESPACE = re.compile(r"^.*[.:|]")
#: Characters that separate a prefix from the name (``A_``, ``head-``).
_SEPARATOR = re.compile(r"[_\-\s]")


@dataclass(frozen=True)
class FaceRule:
    """One rule of the file: a kind, the shape pairs it holds (sides expanded), and why.

    Attributes
    ----------
    name : str
    kind : {"together", "apart", "only_with"}
    pairs : tuple of (str, str)
        ARKit-style names (``eyeLookOut_L``); for ``only_with``, (shape, the shape it needs).
    why : str
    """

    name: str
    kind: Kind
    pairs: tuple[Pair, ...]
    why: str


@dataclass(frozen=True)
class MatchedRules:
    """The rules that apply to one rig, as constraints on its shape names.

    Attributes
    ----------
    together, apart : tuple of (str, str)
        Pairs of the rig's names to add to the artist's.
    excluded : dict of str -> str
        Shapes left out of the session (``only_with`` rules, and a gaze shape whose partner is missing),
        with the reason.
    applied : list of dict
        ``{"rule", "kind", "shapes", "why"}`` for every pair applied, for ``expressions.json``.
    notes : list of str
        Rules that could not be applied as written, and why.
    """

    together: tuple[Pair, ...] = ()
    apart: tuple[Pair, ...] = ()
    excluded: dict[str, str] = field(default_factory=dict)
    applied: list[dict[str, Any]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


def read_rules(path: str | PathLike[str] | None = None) -> tuple[FaceRule, ...]:
    """The rules of a TOML file (default: the one shipped, `RULES_FILE`).

    Raises
    ------
    ValueError
        Naming the file and the rule at fault (not TOML, an unknown kind, a pair that is not two names).
    """
    if path is None:
        source = resources.files("packing").joinpath(RULES_FILE)
        where, text = RULES_FILE, source.read_text(encoding="utf-8")
    else:
        where = str(path)
        try:
            text = Path(path).read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as error:
            raise HarnessError(f"{where}: cannot read the rules file: {error}") from None
    try:
        document = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise HarnessError(f"{where}: not TOML: {error}") from None
    return tuple(_rule(entry, f"{where}: rule {number}") for number, entry in enumerate(document["rule"], 1))


def _rule(entry: Mapping[str, Any], where: str) -> FaceRule:
    name, kind, why, pairs = (entry.get(key) for key in ("name", "kind", "why", "pairs"))
    if not isinstance(name, str) or not isinstance(why, str) or not why.strip():
        raise HarnessError(f"{where}: needs a 'name' and a 'why'")
    if kind not in KINDS:
        raise HarnessError(f"{where} ({name}): kind {kind!r} is not one of {', '.join(KINDS)}")
    if not isinstance(pairs, list) or not all(
        isinstance(pair, list) and len(pair) == 2 and all(isinstance(shape, str) for shape in pair)
        for pair in pairs
    ):
        raise HarnessError(f"{where} ({name}): 'pairs' must be a list of two shape names each")
    expanded = [_sided(pair, side) for pair in pairs for side in _sides(pair)]
    return FaceRule(name, kind, tuple(dict.fromkeys(expanded)), " ".join(why.split()))


def _sides(pair: Sequence[str]) -> tuple[str, ...]:
    return ("L", "R") if any("{side}" in shape or "{other}" in shape for shape in pair) else ("",)


def _sided(pair: Sequence[str], side: str) -> Pair:
    other = {"L": "R", "R": "L", "": ""}[side]
    first, second = (shape.replace("{side}", side).replace("{other}", other) for shape in pair)
    return first, second


def name_keys(name: str) -> tuple[tuple[str, str], ...]:
    """The keys a shape name may stand for: ``(base, side)`` with the base lower-case and alphanumeric and
    the side ``l``, ``r`` or empty; first the whole name, then the name without each prefix
    (``head_eyeBlinkLeft`` -> ``("headeyeblink", "l")``, ``("eyeblink", "l")``)."""
    side = ""
    rest = name.strip()
    suffix = _SIDE_SUFFIX.search(rest)
    if suffix:
        side = (suffix.group("sep") or suffix.group("word"))[0].lower()
        rest = rest[: suffix.start()]
    rest = _NAMESPACE.sub("", rest)
    prefix = _SIDE_PREFIX.match(rest) if not side else None
    if prefix:
        side = prefix.group("side")[0].lower()
        rest = rest[prefix.end() :]
    starts = [0, *(match.end() for match in _SEPARATOR.finditer(rest))]
    keys = (re.sub(r"[^0-9a-z]", "", rest[start:].lower()) for start in starts)
    return tuple(dict.fromkeys((key, side) for key in keys if key))


def match_rules(
    names: Sequence[str],
    rules: Iterable[FaceRule],
    *,
    together: Iterable[Pair] = (),
    apart: Iterable[Pair] = (),
    skip: Iterable[str] = (),
    single: bool = False,
) -> MatchedRules:
    """The rules that apply to a rig with shapes ``names``, under the artist's constraints.

    Parameters
    ----------
    names : sequence of str
        The rig's shape names.
    rules : iterable of FaceRule
    together, apart : iterable of (str, str)
        The artist's pairs: they win over a rule that contradicts them (the rule is dropped, with a note).
    skip : iterable of str
        Shapes not in the session (excluded by the user, or empty): rules naming them do nothing, and a
        together rule's other shape is left out too (it cannot be posed without its partner).
    single : bool
        Every expression holds one shape (a cap of 1, sec. 6): a together rule's shapes are left out, as
        neither can be posed without the other.

    Returns
    -------
    MatchedRules
    """
    lookup = _lookup(names)
    skipped = set(skip)
    given_together = {frozenset(pair) for pair in together}
    given_apart = {frozenset(pair) for pair in apart}
    partnered = {shape for pair in given_together for shape in pair}
    matched = MatchedRules()
    kept: dict[Kind, list[Pair]] = {kind: [] for kind in KINDS}
    for rule in rules:
        for first, second in rule.pairs:
            found = [_find(shape, lookup) for shape in (first, second)]
            if None in found:
                continue
            a, b = found
            reason = _conflict(rule, a, b, given_together, given_apart, partnered, skipped)
            if reason == "absent":
                continue
            if reason:
                matched.notes.append(f"rule {rule.name} ({a}+{b}) not applied: {reason}")
                continue
            kept[rule.kind].append((a, b))
            matched.applied.append({"rule": rule.name, "kind": rule.kind, "shapes": [a, b], "why": rule.why})
    for a, b in kept["only_with"]:
        matched.excluded[a] = f"scanned only with {b} (rule {_rule_of(matched, a, b)})"
    for a, b in kept["together"]:
        rule = f"rule {_rule_of(matched, a, b)}"
        for shape, partner in ((a, b), (b, a)):
            if shape in skipped:
                continue
            if single or partner in skipped:
                why = "an expression holds one shape" if single else f"{partner} is not in the session"
                matched.excluded[shape] = f"not posed without {partner}, and {why} ({rule})"
    gone = set(matched.excluded) | skipped
    final = {kind: [pair for pair in kept[kind] if not gone & set(pair)] for kind in ("together", "apart")}
    matched.applied[:] = [
        entry for entry in matched.applied if entry["kind"] == "only_with" or not gone & set(entry["shapes"])
    ]
    return MatchedRules(
        together=tuple(dict.fromkeys(final["together"])),
        apart=tuple(dict.fromkeys(final["apart"])),
        excluded=matched.excluded,
        applied=matched.applied,
        notes=matched.notes,
    )


def _rule_of(matched: MatchedRules, a: str, b: str) -> str:
    return next(entry["rule"] for entry in matched.applied if entry["shapes"] == [a, b])


def _conflict(
    rule: FaceRule,
    a: str,
    b: str,
    given_together: set[frozenset[str]],
    given_apart: set[frozenset[str]],
    partnered: set[str],
    skipped: set[str],
) -> str:
    """Why the rule's pair (a, b) of the rig cannot be applied: ``"absent"`` (a shape is not in the
    session; nothing to say), a contradiction with the artist's constraints, or "" when it applies."""
    pair = frozenset((a, b))
    if rule.kind == "apart":
        if a in skipped or b in skipped:
            return "absent"
        return "the artist keeps the two together (--together)" if pair in given_together else ""
    if rule.kind == "only_with":
        if a in skipped or pair in given_together:
            return "absent"
        if a in partnered:
            return f"the artist pairs {a} with another shape (--together)"
        return ""
    if (a in skipped and b in skipped) or pair in given_together:
        return "absent"
    if pair in given_apart:
        return "the artist keeps the two apart (--apart)"
    taken = [shape for shape in (a, b) if shape in partnered]
    if taken:
        return f"the artist pairs {' and '.join(taken)} with another shape (--together)"
    return ""


def _lookup(names: Sequence[str]) -> dict[tuple[str, str], list[tuple[int, str]]]:
    """Key -> the names bearing it, each with the rank of the key among its name's (0: the whole name)."""
    lookup: dict[tuple[str, str], list[tuple[int, str]]] = {}
    for name in names:
        for rank, key in enumerate(name_keys(name)):
            lookup.setdefault(key, []).append((rank, name))
    return lookup


def _find(shape: str, lookup: Mapping[tuple[str, str], list[tuple[int, str]]]) -> str | None:
    """The rig name a rule's shape stands for: the one bearing its key with the fewest prefixes removed, or
    None when no name (or more than one equally) bears it."""
    candidates = lookup.get(name_keys(shape)[0], [])
    if not candidates:
        return None
    best = min(rank for rank, _ in candidates)
    closest = [name for rank, name in candidates if rank == best]
    return closest[0] if len(closest) == 1 else None
