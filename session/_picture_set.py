"""The pictures every expression of a session has, as the renderer (`session._pictures`) makes them and the
scan sheet (`session._sheet`) shows them: their keys in an expression's ``files``, their sizes, and the
`Legend` of the coloured one.

Both sides read these from here, so that neither the renderer nor the sheet needs the other.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

#: Key (in an expression's ``files``) of the coloured front picture, and of the bare poses with the turn
#: of their camera from the front in degrees.
PAINTED = "front"
POSES = {"front_pose": 0.0, "three_quarter_pose": 35.0}
#: Size of the coloured picture in pixels (width, height); the face takes `FACE_SHARE` of its width on
#: the left, the legend the rest. A pose picture is the face's part alone.
SIZE = (420, 400)
FACE_SHARE = 0.62
#: Each shape of an expression as its picture shows it: ``(plain words, shape name, RGB colour, extra?)``.
Legend = list[tuple[str, str, np.ndarray, bool]]


def face_size() -> tuple[int, int]:
    """(width, height) in pixels of the face in every picture: a pose picture's size."""
    return round(FACE_SHARE * SIZE[0]), SIZE[1]


def picture_files(files: Mapping[str, str]) -> list[tuple[str, str]]:
    """(key, file) of an expression's pictures as the scan sheet shows them: coloured, then the poses."""
    return [(key, files[key]) for key in (PAINTED, *POSES) if key in files]
