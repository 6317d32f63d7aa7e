"""Blendshape names in plain words for the scan sheet: ``eyeBlink_L`` -> "left eye blink".

Names are split at case changes, digits and separators; a side token (``_L``, ``Left``, ``l_``, ... as
`rigs.side_of` reads them) becomes "left" or "right" in front; everything is lower case. Sides are the
actor's own, as in ARKit's names (``eyeBlinkLeft`` closes the actor's left eye, which a front picture
shows on its right). A side on the jaw or the mouth alone is a direction (``jawLeft``: the jaw moves to
the actor's left).
"""

from __future__ import annotations

import re

_WORDS = re.compile(r"[A-Z]+(?![a-z])|[A-Z]?[a-z]+|\d+")
_SIDE_WORDS = {"l", "r", "left", "right", "lt", "rt"}
#: Parts whose side-named shape moves the part sideways rather than naming one of two.
_MOVING_PARTS = {"jaw", "mouth"}


def plain_words(name: str) -> str:
    """The blendshape ``name`` in plain lower-case words, its side (if any) first.

    Examples
    --------
    >>> plain_words("eyeBlink_L"), plain_words("mouthSmileRight"), plain_words("jawOpen")
    ('left eye blink', 'right mouth smile', 'jaw open')
    >>> plain_words("AU12_lipCornerPuller"), plain_words("brow.R"), plain_words("jawLeft")
    ('au 12 lip corner puller', 'right brow', "jaw to the actor's left")
    """
    import rigs

    side = rigs.side_of(name)
    words = [word.lower() for word in _WORDS.findall(name)]
    if side is not None:
        words = [word for word in words if word not in _SIDE_WORDS] or words
        side_word = "left" if side == "L" else "right"
        if len(words) == 1 and words[0] in _MOVING_PARTS:
            return f"{words[0]} to the actor's {side_word}"
        words.insert(0, side_word)
    return " ".join(words) or name
