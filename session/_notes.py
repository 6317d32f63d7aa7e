"""The TD's notes of the scan sheet: what packing did and left out, each as a plain sentence.

The actor's pages of the sheet say what to do; what the TD should know (how the expressions were chosen,
which face rules held, which shapes are in no expression and why, what the rig's reader or the analysis
noticed) goes to a page of its own, in sentences without the identifiers of the rules or references to the
paper. ``expressions.json`` keeps the identifiers (``constraints``, ``excluded``, ``warnings``).

`td_notes` makes the sentences from the document (its parameters, ``constraints`` and ``excluded``) and
from the notes packing gave (`session._pack`), each said in plain words where its form is known and kept as
it is (without references to the paper, `plain_note`) where it is not.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping, Sequence
from typing import Any

#: What each shipped face rule keeps, in plain words.
_RULES = {
    "gaze-conjugate": "both eyes look the same way",
    "gaze-divergent": "the eyes never look apart",
    "lid-hides-eye": "a closed eyelid is not scanned with a gaze of that eye",
    "lid-antagonists": "an eye is not closed and opened wide at once",
    "mouthClose-corrective": "mouthClose is scanned only with jawOpen",
    "tongue-through-lips": "the tongue does not come out between closed lips",
    "jaw-opposites": "the jaw does not move both ways at once",
    "mouth-opposites": "the mouth does not move both ways at once",
    "mouth-corner-antagonists": "a mouth corner is not raised and lowered at once",
    "puff-needs-sealed-lips": "the cheeks are puffed with sealed lips",
}

#: A reference to the paper in a note: ``(eq. 2)``, ``(eqs. 6-7)``, ``, sec. 4.4.1`` and the like.
_REFERENCE = re.compile(
    r"\s*\((?:eqs?|sec|secs|Algorithm|Alg)\.?\s[^()]*\)|,\s*(?:eqs?|secs?)\.\s[\d.\-\u2013, and]*\d(?=\))"
    r"|\s*\b(?:eqs?|secs?)\.\s[\d.\-\u2013]*\d",
    re.IGNORECASE,
)


def plain_note(note: str) -> str:
    """``note`` without its references to the paper's equations, sections and algorithms.

    Examples
    --------
    >>> plain_note("no target neutral: triangle distortion (eqs. 6-7) is 0")
    'no target neutral: triangle distortion is 0'
    >>> plain_note("not paired (they spread over both halves, sec. 4.4.1): jawLeft+jawRight")
    'not paired (they spread over both halves): jawLeft+jawRight'
    """
    return _REFERENCE.sub("", note)


def td_notes(document: Mapping[str, Any], notes: Sequence[str] = ()) -> list[str]:
    """The TD's notes: how the expressions were chosen, the face rules, the shapes in no expression, then
    each of ``notes`` (packing's analysis notes and warnings) as a plain sentence (those the document
    says already are left out).

    Examples
    --------
    >>> document = {"solver": "cpsat", "params": {"mu": 0.3, "symmetry": True}, "expressions": [],
    ...             "excluded": [{"shape": "mouthClose", "reason": "left out by the default constraints: "
    ...                           "scanned only with jawOpen (rule mouthClose-corrective)"}]}
    >>> td_notes(document, ["no target neutral: triangle distortion (eqs. 6-7) is 0"])[-2:]
    ['1 shape is in no expression: mouthClose (scanned only with jawOpen).', 'No actor neutral was given \
(--target), so how important a shape is comes from how far it moves alone.']
    """
    sentences = [_choice(document), *_rules(document.get("constraints")), *_excluded(document)]
    for note in notes:
        said = _said(note)
        if said:
            sentences.append(said)
    return sentences


def _choice(document: Mapping[str, Any]) -> str:
    params = document.get("params", {})
    count = len(document.get("expressions", []))
    words = [
        f"The {_count(count, 'expression')} {'were' if count != 1 else 'was'} chosen by "
        f"{document.get('solver', 'the solver')}, in priority order: a session cut short has the most "
        "important shapes",
        f"a shape moves the vertices that move at least {float(params.get('mu', 0.3)):.0%} as far as its "
        f"farthest (mu {params.get('mu')})",
        "left and right shapes are scanned together" if params.get("symmetry") else "left and right apart",
    ]
    if params.get("max_per_expression"):
        words.append(f"at most {_count(params['max_per_expression'], 'shape')} per expression")
    return "; ".join(words) + "."


def _rules(constraints: Mapping[str, Any] | None) -> list[str]:
    if not constraints:
        return []
    if not constraints.get("default"):
        return ["The face rules were off (--no-default-constraints)."]
    rules = constraints.get("rules", [])
    if not rules:
        return ["No face rule matches the rig's shape names."]
    kinds = {kind: sum(rule["kind"] == kind for rule in rules) for kind in ("together", "apart", "only_with")}
    held = [
        f"joined {_count(kinds['together'], 'pair')} of shapes" if kinds["together"] else "",
        f"kept {_count(kinds['apart'], 'pair')} apart" if kinds["apart"] else "",
        f"kept {_count(kinds['only_with'], 'shape')} for scanning with another only"
        if kinds["only_with"]
        else "",
    ]
    why = list(dict.fromkeys(_RULES[entry["rule"]] for entry in rules if entry["rule"] in _RULES))
    sentence = "The face rules " + _listed([part for part in held if part])
    sentence += f", so that every expression is one a face can hold ({'; '.join(why)})" if why else ""
    sentences = [sentence + "; expressions.json lists each pair with its reason."]
    for note in constraints.get("notes", []):
        found = re.match(r"rule \S+ \((\S+)\+(\S+)\) not applied: (.*)$", note)
        sentences.append(
            f"A face rule for {found[1]} and {found[2]} was not applied: {found[3]}."
            if found
            else _sentence(plain_note(note))
        )
    return sentences


def _excluded(document: Mapping[str, Any]) -> list[str]:
    excluded = document.get("excluded", [])
    if not excluded:
        return []
    by_reason: dict[str, list[str]] = {}
    for entry in excluded:
        by_reason.setdefault(_reason(entry["reason"]), []).append(entry["shape"])
    listed = "; ".join(f"{', '.join(names)} ({reason})" for reason, names in by_reason.items())
    count = len(excluded)
    return [f"{_count(count, 'shape')} {'are' if count != 1 else 'is'} in no expression: {listed}."]


def _reason(reason: str) -> str:
    """An ``excluded`` reason in plain words."""
    reason = re.sub(r"\s*\(rule [^()]*\)", "", plain_note(reason))
    for start in ("left out by the default constraints: ", "in no expression: "):
        reason = reason.removeprefix(start)
    return reason


def _pairs(listed: str) -> str:
    """``a+b (32%), c+d (55%)`` -> ``a and b, c and d``."""
    pairs = [re.sub(r"\s*\(.*\)$", "", pair.strip()) for pair in listed.split(", ")]
    return ", ".join(" and ".join(pair.split("+", 1)) for pair in pairs)


#: Packing's notes in plain words, by their form (None: the document says it already).
_FORMS: list[tuple[re.Pattern[str], Callable[[re.Match[str]], str | None]]] = [
    (re.compile(r"default constraints|\d+ shapes? left out of the session"), lambda _: None),
    (re.compile(r"\d+ empty blendshapes? excluded|\d+ blendshapes? in no expression"), lambda _: None),
    (
        re.compile(r"(\d+) mirror matches overlap on more than \S+ of their active vertices .*?: (.*)$"),
        lambda m: (
            f"{_count(int(m[1]), 'left/right pair')} {'are' if m[1] != '1' else 'is'} scanned apart, "
            f"because each of the shapes moves both sides of the face: {_pairs(m[2])}."
        ),
    ),
    (
        re.compile(r"motion symmetry skipped region pairs .*: rig has no such regions"),
        lambda _: (
            "Upper and lower lip and eyelid shapes were not paired by how they move: the rig has no "
            "lip or eyelid regions (--regions gives them)."
        ),
    ),
    (
        re.compile(r"no target neutral"),
        lambda _: (
            "No actor neutral was given (--target), so how important a shape is comes from how far it "
            "moves alone."
        ),
    ),
    (
        re.compile(r"(\d+) symmetry pairs? kept together \((\d+) mirror, (\d+) motion\)"),
        lambda m: (
            f"{_count(int(m[1]), 'pair')} of shapes {'are' if m[1] != '1' else 'is'} always scanned "
            f"together: {m[2]} found as mirror images, {m[3]} by opposite motion of the lips or eyelids, the "
            "others joined by the face rules or --together."
        ),
    ),
    (re.compile(r"symmetry off: no pairs"), lambda _: "No left/right pairs were made (symmetry off)."),
    (
        re.compile(r"mirror pairs whose left/right names are not twins \(check them\): (.*)$"),
        lambda m: (
            f"These shapes mirror each other but their names do not pair them; check them: {_pairs(m[1])}."
        ),
    ),
    (
        re.compile(r"left/right-named twins that geometry did not pair.*?: (.*)$"),
        lambda m: (
            "These shapes are named as left and right twins but do not mirror each other, so they are "
            f"not kept together: {m[1].replace('/', ' and ')}."
        ),
    ),
    (
        re.compile(r"(\S+)\+(\S+) detected as a pair but kept apart by the artist constraints"),
        lambda m: f"{m[1]} and {m[2]} mirror each other but are kept apart, as --apart asks.",
    ),
    (
        re.compile(r"(\d+) of (\d+) vertices have no mirror vertex"),
        lambda m: (
            f"{m[1]} of the {m[2]} vertices have no mirror image across the middle of the face; shapes "
            "that move them may go unpaired."
        ),
    ),
]


def _said(note: str) -> str | None:
    """``note`` as a plain sentence; None for what the document says already."""
    for form, say in _FORMS:
        found = form.match(note)
        if found:
            return say(found)
    return _sentence(plain_note(note))


def _sentence(text: str) -> str:
    text = text.strip()
    return text[:1].upper() + text[1:] + ("" if text.endswith((".", "!", "?")) else ".")


def _count(count: int, noun: str) -> str:
    return f"{count} {noun}{'' if count == 1 else 's'}"


def _listed(parts: Sequence[str]) -> str:
    return parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1]
