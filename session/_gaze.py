"""Where the eyes look, drawn on the pictures of an expression with a gaze shape.

A gaze is hard to see on a rendered face: the eyes are often separate meshes without morph targets (left
out of the rig), and a grey eyeball turned a few degrees looks like one that is not. So the pictures of an
expression with an ``eyeLook*`` shape (`session._actor.is_gaze`) carry an arrow per such shape, from where
the shape moves the eye region to the way it moves it: the mean displacement of the shape's active
vertices (eq. 2) that face the camera (the front of an eyeball, or the lids and skin a rig without eyes
moves), seen in the picture's own view. The arrow is the shape's own motion, so it points the way the
picture's eye turns whatever the rig calls its sides.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from session._actor import is_gaze

if TYPE_CHECKING:
    from PIL import ImageDraw

    from render import Frame
    from rigs import Rig

#: Vertices whose normal is within this cosine of the view direction count as facing the camera.
_FACING = 0.3
#: An arrow is this many times as long as the eye region it starts in is wide (pixels at least `_SHORTEST`).
_LENGTH, _SHORTEST = 0.9, 12.0
#: Line widths (pixels) of the arrow and of the light halo around it.
_LINE, _HALO = 2, 5


@dataclass(frozen=True)
class Arrow:
    """An arrow in a picture's pixels: from ``start`` (x, y) to ``end``."""

    start: tuple[float, float]
    end: tuple[float, float]


def gaze_arrows(
    rig: Rig,
    names: Sequence[str],
    active: np.ndarray,
    normals: np.ndarray,
    posed: np.ndarray,
    frame: Frame,
) -> list[Arrow]:
    """One `Arrow` per gaze shape among ``names`` in the picture of ``frame``.

    Parameters
    ----------
    rig : rigs.Rig
    names : sequence of str
        The shapes of the expression.
    active : (K, N) bool array
        The rig's active vertices (eq. 2).
    normals : (N, 3) array
        The neutral's vertex normals.
    posed : (N, 3) array
        The expression's pose.
    frame : render.Frame
        The picture's view.
    """
    arrows = []
    facing = normals @ frame.camera[2] >= _FACING
    for name in names:
        if not is_gaze(name):
            continue
        k = rig.index(name)
        chosen = active[k] & facing
        if not chosen.any():
            chosen = active[k]
        if not chosen.any():
            continue
        moved = frame.project(posed[chosen])[:, :2] / frame.supersample
        before = frame.project(posed[chosen] - rig.deltas[k][chosen])[:, :2] / frame.supersample
        direction = (moved - before).mean(axis=0)
        size = float(np.linalg.norm(direction))
        if size <= 1e-9:
            continue
        start = before.mean(axis=0)
        length = max(_LENGTH * float(np.ptp(before, axis=0).max()), _SHORTEST)
        end = start + direction / size * length
        arrows.append(Arrow((float(start[0]), float(start[1])), (float(end[0]), float(end[1]))))
    return arrows


def draw_arrows(
    draw: ImageDraw.ImageDraw, arrows: Sequence[Arrow], ink: int | tuple, halo: int | tuple
) -> None:
    """Draw ``arrows`` in ``ink`` over a ``halo`` that keeps them visible on any shade."""
    for width, colour in ((_HALO, halo), (_LINE, ink)):
        for arrow in arrows:
            start, end = np.asarray(arrow.start), np.asarray(arrow.end)
            along = (end - start) / max(float(np.linalg.norm(end - start)), 1e-9)
            across = np.array([-along[1], along[0]])
            head = 3.0 * width + 4.0
            base = end - along * head
            draw.line([tuple(start), tuple(base)], fill=colour, width=width)
            tip = [
                tuple(end + along * (width - _LINE)),
                tuple(base + across * head * 0.55),
                tuple(base - across * head * 0.55),
            ]
            draw.polygon(tip, fill=colour)
