"""What the actor does for an expression, in the actor's words: the steps of the scan sheet.

An expression is a set of blendshapes held at once. The actor is told what to do, one step per part of the
face, in the order an expression is built up: the jaw, the mouth and the tongue, the cheeks and the nose, the
brows, the eyelids, and last where to look. A shape named the ARKit way (`eyeBlinkLeft`, `mouthSmile_R`,
namespaced or prefixed as `packing`'s face rules read them) becomes an instruction (``Close your left eye``);
the two sides of one shape become one step (``Smile with both corners of your mouth``); the gaze shapes of
both eyes become one direction (``Look to your left``). Left and right are the actor's own, as ARKit's names
are. A shape of another naming is said in plain words (`session._words.plain_words`).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass

from session._words import plain_words

#: Parts of the face in the order the steps come, and each ARKit shape's part and instruction: one side
#: (``{side}`` is ``left`` or ``right``) and, where both sides make one step, both.
_ORDER = ("jaw", "mouth", "tongue", "cheeks", "nose", "brows", "lids", "gaze")
_ACTIONS: dict[str, tuple[str, str, str | None]] = {
    "jawopen": ("jaw", "Open your jaw wide", None),
    "jawforward": ("jaw", "Push your jaw forward", None),
    "jaw": ("jaw", "Move your jaw to your {side}", None),
    "mouthclose": ("mouth", "Close your lips while your jaw stays open", None),
    "mouth": ("mouth", "Move your closed lips to your {side}", None),
    "mouthfunnel": ("mouth", "Funnel your lips, open, as in \u201cwho\u201d", None),
    "mouthpucker": ("mouth", "Pucker your lips, as for a kiss", None),
    "mouthrollupper": ("mouth", "Roll your upper lip in over your teeth", None),
    "mouthrolllower": ("mouth", "Roll your lower lip in over your teeth", None),
    "mouthshrugupper": ("mouth", "Push your upper lip up", None),
    "mouthshruglower": ("mouth", "Push your lower lip up (pout)", None),
    "mouthsmile": (
        "mouth",
        "Smile with the {side} corner of your mouth",
        "Smile with both corners of your mouth",
    ),
    "mouthfrown": ("mouth", "Pull the {side} corner of your mouth down", "Pull both mouth corners down"),
    "mouthdimple": (
        "mouth",
        "Press the {side} corner of your mouth back (dimple)",
        "Press both mouth corners back (dimples)",
    ),
    "mouthstretch": (
        "mouth",
        "Stretch the {side} corner of your mouth out and down",
        "Stretch both mouth corners out and down",
    ),
    "mouthpress": ("mouth", "Press your lips together on the {side}", "Press your lips together"),
    "mouthupperup": (
        "mouth",
        "Raise your upper lip on the {side}, showing the upper teeth",
        "Raise your upper lip, showing the upper teeth",
    ),
    "mouthlowerdown": (
        "mouth",
        "Pull your lower lip down on the {side}, showing the lower teeth",
        "Pull your lower lip down, showing the lower teeth",
    ),
    "tongueout": ("tongue", "Stick your tongue out", None),
    "cheekpuff": ("cheeks", "Puff your cheeks out with air", None),
    "cheeksquint": ("cheeks", "Raise your {side} cheek", "Raise both cheeks"),
    "nosesneer": ("nose", "Wrinkle your nose on the {side} (sneer)", "Wrinkle your nose (sneer)"),
    "browdown": ("brows", "Lower your {side} brow", "Lower both brows (frown)"),
    "browinnerup": ("brows", "Raise the inner ends of your brows", None),
    "browouterup": ("brows", "Raise the outer end of your {side} brow", "Raise the outer ends of both brows"),
    "eyeblink": ("lids", "Close your {side} eye", "Close both eyes"),
    "eyesquint": ("lids", "Squint your {side} eye", "Squint both eyes"),
    "eyewide": ("lids", "Open your {side} eye wide", "Open both eyes wide"),
}
#: Gaze shapes: where an eye turns, ``in`` towards the nose and ``out`` away from it.
_GAZE = {"eyelookup": "up", "eyelookdown": "down", "eyelookin": "in", "eyelookout": "out"}
_WORDS = re.compile(r"[A-Z]+(?![a-z])|[A-Z]?[a-z]+|\d+")
_SIDE_WORDS = {"l", "r", "left", "right", "lt", "rt"}


@dataclass(frozen=True)
class Step:
    """One thing the actor does: ``text`` in the actor's words and the ``shapes`` (rig names) it holds;
    ``again`` when they were scanned already and are held again in this combination."""

    text: str
    shapes: tuple[str, ...]
    again: bool = False


def shape_key(name: str) -> tuple[str, str | None]:
    """``(base, side)`` of a shape name: the base ARKit's way, lower case without its side (the longest
    ARKit base the name ends with, so ``blendShape1.eyeBlink_L`` is ``eyeblink``), the side ``L``, ``R`` or
    None (`rigs.side_of`).

    Examples
    --------
    >>> shape_key("head_mouthSmile_R"), shape_key("jawOpen"), shape_key("AU12")
    (('mouthsmile', 'R'), ('jawopen', None), ('au12', None))
    """
    import rigs

    words = [word.lower() for word in _WORDS.findall(name)]
    words = [word for word in words if word not in _SIDE_WORDS] or words
    for start in range(len(words)):
        key = "".join(words[start:])
        if key in _ACTIONS or key in _GAZE:
            return key, rigs.side_of(name)
    return "".join(words), rigs.side_of(name)


def is_gaze(name: str) -> bool:
    """Whether ``name`` is a gaze shape (``eyeLookUp_L``, ``eyeLookInRight``, ...)."""
    return shape_key(name)[0] in _GAZE


def actor_steps(shapes: Sequence[str], again: Sequence[str] = ()) -> list[Step]:
    """The steps of an expression holding ``shapes`` (and, held again, ``again``), in the order of
    `_ORDER` (shapes of other names last, in their order).

    Examples
    --------
    >>> [step.text for step in actor_steps(["eyeBlinkLeft", "jawOpen", "eyeBlinkRight"])]
    ['Open your jaw wide', 'Close both eyes']
    >>> [step.text for step in actor_steps(["eyeLookOutLeft", "eyeLookInRight"])]
    ['Look to your left']
    """
    steps = [*_steps(shapes, False), *_steps(again, True)]
    rank = {part: index for index, part in enumerate(_ORDER)}
    return [step for _, step in sorted(steps, key=lambda item: rank.get(item[0], len(rank)))]


def _steps(shapes: Sequence[str], again: bool) -> list[tuple[str, Step]]:
    keyed = [(name, *shape_key(name)) for name in shapes]
    steps: list[tuple[str, Step]] = []
    gaze = [(name, base, side) for name, base, side in keyed if base in _GAZE]
    if gaze:
        steps.append(("gaze", Step(_look(gaze), tuple(name for name, _, _ in gaze), again)))
    done = {name for name, _, _ in gaze}
    for name, base, side in keyed:
        if name in done:
            continue
        part, one, both = _ACTIONS.get(base, ("", "", None))
        twin = next(
            (other for other, b, s in keyed if other not in done and b == base and {s, side} == {"L", "R"}),
            None,
        )
        if both is not None and twin is not None:
            steps.append((part, Step(both, (name, twin), again)))
            done.update((name, twin))
            continue
        done.add(name)
        if both is not None and side is None:  # (one shape for both sides: eyeBlink)
            steps.append((part, Step(both, (name,), again)))
        elif not one or ("{side}" in one and side is None):
            words = plain_words(name)
            steps.append((part, Step(words[:1].upper() + words[1:], (name,), again)))
        else:
            steps.append((part, Step(one.format(side="left" if side == "L" else "right"), (name,), again)))
    return steps


def _look(gaze: Sequence[tuple[str, str, str | None]]) -> str:
    """Where the actor looks for the gaze shapes ``(name, base, side)`` of an expression: up or down and
    to the actor's left or right (an eye's ``out`` is towards its own side)."""
    vertical, across = [], []
    for _, base, side in gaze:
        turn = _GAZE[base]
        if turn in ("up", "down"):
            vertical.append(turn)
        elif side is not None:
            across.append(side if turn == "out" else {"L": "R", "R": "L"}[side])
    words = list(dict.fromkeys(vertical))
    words += [f"to your {'left' if side == 'L' else 'right'}" for side in dict.fromkeys(across)]
    return "Look " + " and ".join(words) if words else "Look straight ahead"
