"""The pictures of a scanning session, in ``pictures/``, for every expression:

* ``expression_XX_front.png``: the template posed in the expression, seen from the front found from the
  face (`rigs.frontal_camera`), each active shape coloured (`harness._session_render.triangle_colours`)
  and named on the right in plain words with its colour;
* ``expression_XX_front_pose.png`` and ``expression_XX_three_quarter_pose.png``: the same pose bare, in
  grey, from the front and turned 35 degrees towards the character's left (`rigs.three_quarter_camera`),
  so that the form of the pose shows, which the colours cover.

All the pictures of one view share one `Frame`, fitted to every expression, so they compare at one scale
and place, and the part of the face an expression does not move is rasterised once for all of them
(`Backdrop`). Expressions are rendered on a pool of threads (numpy's array loops and Pillow's drawing and
PNG encoding run without Python's global lock), one per processor this process may use.
"""

from __future__ import annotations

import importlib.util
import io
import os
import threading
from collections.abc import Iterator, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from harness._session_mesh import expression_name, expression_poses
from harness._session_render import (
    Backdrop,
    Frame,
    Motion,
    active_vertices,
    triangle_colours,
    vertex_normals,
)

if TYPE_CHECKING:
    from PIL import Image, ImageDraw, ImageFont

    from harness._session_sheet import Legend
    from rigs import Rig

PICTURES = "pictures"
#: Key (in an expression's ``files``) of the coloured front picture, and of the bare poses with the turn
#: of their camera from the front in degrees.
PAINTED = "front"
POSES = {"front_pose": 0.0, "three_quarter_pose": 35.0}
#: Size of the coloured picture in pixels (width, height); the face takes `FACE_SHARE` of its width on
#: the left, the legend the rest. A pose picture is the face's part alone.
SIZE = (420, 400)
FACE_SHARE = 0.62
BACKGROUND = np.array([1.0, 1.0, 1.0])
#: Grey level of a bare pose (its pictures are greyscale on white: a third of the data to encode).
CLAY = 0.84
#: zlib level of the PNG pictures: level 1 writes them about four times as fast as the default 6, for
#: files about a third larger.
_PNG_LEVEL = 1
#: Legend text height in pixels; the legend shrinks down to the smallest to fit its lines.
_LEGEND_PX, _SMALLEST_PX = 11, 6


def face_size() -> tuple[int, int]:
    """(width, height) in pixels of the face in every picture: a pose picture's size."""
    return round(FACE_SHARE * SIZE[0]), SIZE[1]


def session_pictures(
    rig: Rig,
    expressions: Sequence[dict[str, Any]],
    legends: Sequence[Legend],
    mu: float,
    *,
    workers: int | None = None,
) -> Iterator[tuple[str, bytes]]:
    """(file name, PNG) of the pictures of every expression, in order; records each in its expression's
    ``files`` under `PAINTED` or a key of `POSES`.

    Parameters
    ----------
    rig : rigs.Rig
    expressions : sequence of dict
        ``expressions.json``'s expressions (``shapes`` and ``extra_examples``).
    legends : sequence of Legend
        Per expression, its shapes in legend order with their words and colours.
    mu : float
        The threshold the expressions were packed with: the active vertices coloured (eq. 2).
    workers : int, optional
        Threads rendering expressions at once; by default one per processor this process may use.
    """
    import rigs

    if not expressions:
        return
    neutral, triangles = rig.neutral, rig.triangles
    active = active_vertices(rig, mu)
    poses = neutral + expression_poses(rig, expressions)
    normals = vertex_normals(neutral, triangles)
    front = rigs.frontal_camera(rig)
    width, height = face_size()
    backdrops = {
        key: Backdrop(
            neutral,
            triangles,
            Frame.fitted(
                rigs.three_quarter_camera(front, degrees) if degrees else front,
                [neutral, *poses],
                width=width,
                height=height,
            ),
            normals,
        )
        for key, degrees in POSES.items()
    }

    def render(index: int) -> list[tuple[str, bytes]]:
        legend, posed = legends[index], poses[index]
        colours = np.asarray([entry[2] for entry in legend]).reshape(len(legend), 3)
        fills = triangle_colours(triangles, active[rig.indices([entry[1] for entry in legend])], colours)
        words = [entry[0] + (" (again)" if entry[3] else "") for entry in legend]
        motion = Motion.of(posed, neutral, triangles, normals)
        rasters = {key: backdrop.pose(posed, motion) for key, backdrop in backdrops.items()}
        painted = _legend_picture(rasters["front_pose"].over(fills, BACKGROUND), words, colours)
        bare = [(key, _png(raster.over(CLAY, 1.0))) for key, raster in rasters.items()]
        return [(PAINTED, painted), *bare]

    with ThreadPoolExecutor(workers or _processors()) as pool:
        made = pool.map(render, range(len(expressions)))
        for index, (expression, files) in enumerate(zip(expressions, made, strict=True), start=1):
            name = expression_name(index, len(expressions))
            for key, png in files:
                path = f"{PICTURES}/{name}_{key}.png"
                expression["files"][key] = path
                yield path, png


def _processors() -> int:
    """Processors this process may run on."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def _legend_picture(face: np.ndarray, legend: Sequence[str], colours: np.ndarray) -> bytes:
    """The PNG of `SIZE`: the RGB ``face`` on the left, the legend (a swatch and the words per line) on
    its right, centred vertically, its text shrunk to fit the height and cut to fit the width."""
    from PIL import Image, ImageDraw

    width, height = SIZE
    left = face.shape[1]
    canvas = np.empty((height, width, 3), dtype=np.uint8)
    canvas[:] = np.round(255 * BACKGROUND).astype(np.uint8)
    canvas[:, :left] = face
    image = Image.fromarray(canvas)
    if len(legend):
        _draw_legend(ImageDraw.Draw(image), legend, np.asarray(colours, dtype=np.float64), left, SIZE)
    return _png(image)


def _draw_legend(
    draw: ImageDraw.ImageDraw, legend: Sequence[str], colours: np.ndarray, left: int, size: tuple[int, int]
) -> None:
    width, height = size
    pixels = _LEGEND_PX
    while pixels > _SMALLEST_PX and len(legend) * round(1.3 * pixels) > 0.96 * height:
        pixels -= 1
    font, line = _font(pixels, threading.get_ident()), round(1.3 * pixels)
    swatch = round(0.8 * pixels)
    x, y = left + 4, round((height - len(legend) * line) / 2)
    room = width - (x + swatch + 4) - 2
    for words, colour in zip(legend, colours.reshape(-1, 3), strict=True):
        fill = tuple(int(round(255 * value)) for value in colour)
        draw.rectangle((x, y + (line - swatch) // 2, x + swatch - 1, y + (line + swatch) // 2 - 1), fill=fill)
        draw.text(
            (x + swatch + 4, y + line // 2),
            _fitted(draw, words, font, room),
            fill=(0, 0, 0),
            font=font,
            anchor="lm",
        )
        y += line


def _png(image: np.ndarray | Image.Image) -> bytes:
    """PNG bytes of an RGB or grey image, without a timestamp or software tag (the same image, the same
    bytes)."""
    from PIL import Image

    if isinstance(image, np.ndarray):
        image = Image.fromarray(image)
    buffer = io.BytesIO()
    image.save(buffer, format="PNG", compress_level=_PNG_LEVEL)
    return buffer.getvalue()


def _fitted(draw: ImageDraw.ImageDraw, words: str, font: ImageFont.FreeTypeFont, room: int) -> str:
    """``words``, cut and ended with an ellipsis when wider than ``room`` pixels."""
    if draw.textlength(words, font=font) <= room:
        return words
    while words and draw.textlength(words + "\u2026", font=font) > room:
        words = words[:-1]
    return words.rstrip() + "\u2026"


@lru_cache(maxsize=64)
def _font(pixels: int, thread: int) -> ImageFont.FreeTypeFont:
    """DejaVu Sans at ``pixels`` for one ``thread`` (a FreeType face is not shared between threads): the
    font matplotlib ships (so every machine draws the same glyphs), found in its package data without
    importing it."""
    from PIL import ImageFont

    package = Path(str(importlib.util.find_spec("matplotlib").origin)).parent
    return ImageFont.truetype(str(package / "mpl-data" / "fonts" / "ttf" / "DejaVuSans.ttf"), pixels)


def picture_files(files: Mapping[str, str]) -> list[tuple[str, str]]:
    """(key, file) of an expression's pictures as the scan sheet shows them: coloured, then the poses."""
    return [(key, files[key]) for key in (PAINTED, *POSES) if key in files]
