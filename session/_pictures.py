"""The pictures of a scanning session, in ``pictures/``, for every expression:

* ``expression_XX_front.png``: the template posed in the expression, seen from the front found from the
  face (`rigs.frontal_camera`), each active shape coloured (`render._raster.triangle_colours`)
  and named on the right in plain words with its colour (`legend_layout`: words wrap rather than being
  cut);
* ``expression_XX_front_pose.png`` and ``expression_XX_three_quarter_pose.png``: the same pose bare, in
  grey, from the front and turned 35 degrees towards the character's left (`rigs.three_quarter_camera`),
  so that the form of the pose shows, which the colours cover.

A gaze shape puts an arrow on each of its pictures where the eye turns (`session._gaze`). Twin vertices
along seams shade as one surface, and a face cut out of a larger mesh fades out towards the cut (the
`Scene`'s ``fade``, `render.edge_fade`), rather than showing the cut's staircase of polygons.

All the pictures of one view share one `Frame`, fitted to every expression, so they compare at one scale
and place, and the part of the face an expression does not move is rasterised once for all of them
(`Backdrop`). What no expression changes (the `Scene`: normals, active vertices, front camera) can be
prepared before the expressions are known (`prepare_scene`, while the solver works). Expressions are
rendered on a pool of threads (numpy's array loops and Pillow's PNG encoding run without Python's global
lock), one per processor this process may use.
"""

from __future__ import annotations

import importlib.util
import io
import os
import threading
import zlib
from collections.abc import Iterator, Mapping, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from render import (
    Backdrop,
    Frame,
    Motion,
    Raster,
    active_vertices,
    coincident,
    edge_fade,
    triangle_colours,
    vertex_normals,
)
from session._gaze import Arrow, draw_arrows, gaze_arrows
from session._mesh import expression_name, expression_poses
from session._picture_set import PAINTED, POSES, SIZE, Legend, face_size

if TYPE_CHECKING:
    from PIL import Image, ImageDraw, ImageFont

    from rigs import Rig

PICTURES = "pictures"
BACKGROUND = np.array([1.0, 1.0, 1.0])
#: Grey level of a bare pose (its pictures are greyscale on white: a third of the data to encode).
CLAY = 0.84
#: zlib level of the PNG pictures: level 1 writes them about four times as fast as the default 6, for
#: files about a third larger; its run-length strategy writes them a fifth faster again (rendered faces and
#: flat backgrounds are rows of repeats after PNG's filters), the files a little smaller.
_PNG_LEVEL = 1
_PNG_STRATEGY = zlib.Z_RLE
#: Most threads rendering at once (each holds a few images' worth of samples).
_MOST_THREADS = 8
#: Legend text height in pixels; the legend shrinks down to the smallest to fit its lines.
_LEGEND_PX, _SMALLEST_PX = 11, 6


class Rendering:
    """The pictures of a session being rendered on a pool of threads from the moment it is made
    (`session_pictures`), so that they render while the caller writes other files.

    Iterate it for (file name, PNG) of every picture in order, each recorded in its expression's
    ``files`` under `PAINTED` or a key of `POSES` as it comes; `close` it when done or given up (it stops
    what has not started).
    """

    def __init__(
        self,
        scene: Future[Scene],
        rig: Rig,
        mu: float,
        expressions: Sequence[dict[str, Any]],
        legends: Sequence[Legend],
        workers: int,
    ) -> None:
        self._expressions = expressions
        self._pool = ThreadPoolExecutor(workers, thread_name_prefix="pictures")
        stage = self._pool.submit(_Stage, scene, rig, mu, expressions)
        views = {key: self._pool.submit(_backdrop, stage, degrees) for key, degrees in POSES.items()}
        self._made = [
            self._pool.submit(_render, stage, views, index, legends[index]) for index in range(len(legends))
        ]

    def __iter__(self) -> Iterator[tuple[str, bytes]]:
        count = len(self._expressions)
        for index, (expression, made) in enumerate(zip(self._expressions, self._made, strict=True), start=1):
            for key, png in made.result():
                path = f"{PICTURES}/{expression_name(index, count)}_{key}.png"
                expression["files"][key] = path
                yield path, png

    def close(self) -> None:
        """Stop the pictures not started; those being rendered finish in the background."""
        self._pool.shutdown(wait=False, cancel_futures=True)


def session_pictures(
    rig: Rig,
    expressions: Sequence[dict[str, Any]],
    legends: Sequence[Legend],
    mu: float,
    *,
    workers: int | None = None,
    scene: Future[Scene] | None = None,
) -> Rendering:
    """Start rendering the pictures of every expression (`Rendering`).

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
        Threads rendering at once; by default one per processor this process may use (at most
        `_MOST_THREADS`).
    scene : Future of Scene, optional
        The `Scene` of ``rig`` and ``mu`` prepared ahead (`prepare_scene`); by default it is made here.

    Raises
    ------
    ValueError
        For a ``scene`` of another rig or threshold (when the pictures are read).
    """
    return Rendering(scene or prepare_scene(rig, mu), rig, mu, expressions, legends, workers or _processors())


@dataclass(frozen=True)
class Scene:
    """What every picture of a rig shares whatever its expressions: the neutral's twin vertices along
    seams (`coincident`) and `vertex_normals`, the active vertices (eq. 2, `active_vertices` at the
    threshold ``mu`` the expressions are packed with), the front camera (`rigs.frontal_camera`) and the
    opacity that fades a face cut out of a larger mesh out towards the cut (`edge_fade`, None for none)."""

    rig: Rig
    mu: float
    twins: np.ndarray
    normals: np.ndarray
    active: np.ndarray
    front: np.ndarray
    fade: np.ndarray | None

    @classmethod
    def of(cls, rig: Rig, mu: float) -> Scene:
        """The scene of ``rig`` at the threshold ``mu``."""
        import rigs

        twins = coincident(rig.neutral)
        normals = vertex_normals(rig.neutral, rig.triangles, twins)
        motion = np.zeros(rig.n_vertices)
        for delta in rig.deltas:
            np.maximum(motion, np.linalg.norm(delta, axis=1), out=motion)
        fade = edge_fade(rig.neutral, rig.triangles, motion)
        return cls(rig, mu, twins, normals, active_vertices(rig, mu), rigs.frontal_camera(rig), fade)


def prepare_scene(rig: Rig, mu: float) -> Future[Scene]:
    """Start making the `Scene` of ``rig`` at ``mu`` on a thread of its own (e.g. while the solver
    works), then importing Pillow and its PNG writer; `session_pictures` takes it."""
    pool = ThreadPoolExecutor(1, thread_name_prefix="scene")
    try:
        scene = pool.submit(Scene.of, rig, mu)
        pool.submit(_import_pillow)
        return scene
    finally:
        pool.shutdown(wait=False)


def _import_pillow() -> None:
    """Import Pillow's image, drawing and font modules and its file formats (`PIL.Image.preinit`)."""
    from PIL import Image, ImageDraw, ImageFont  # noqa: F401

    Image.preinit()


class _Stage:
    """What every picture of a session shares: the `Scene` and the expressions' poses."""

    def __init__(
        self, scene: Future[Scene], rig: Rig, mu: float, expressions: Sequence[dict[str, Any]]
    ) -> None:
        shared = scene.result()
        if shared.rig is not rig or shared.mu != mu:
            raise ValueError("the pictures' scene was prepared for another rig or threshold mu")
        self.rig = shared.rig
        self.twins = shared.twins
        self.normals = shared.normals
        self.fade = shared.fade
        self.poses = shared.rig.neutral + expression_poses(shared.rig, expressions)
        self.active = shared.active
        self.front = shared.front


def _backdrop(stage: Future[_Stage], degrees: float) -> Backdrop:
    """The neutral in the frame of the view turned ``degrees`` from the front, fitted to every pose."""
    import rigs

    shared = stage.result()
    neutral = shared.rig.neutral
    camera = rigs.three_quarter_camera(shared.front, degrees) if degrees else shared.front
    width, height = face_size()
    frame = Frame.fitted(camera, [neutral, *shared.poses], width=width, height=height)
    return Backdrop(neutral, shared.rig.triangles, frame, shared.normals, shared.fade)


def _render(
    stage: Future[_Stage], views: Mapping[str, Future[Backdrop]], index: int, legend: Legend
) -> list[tuple[str, bytes]]:
    """(key, PNG) of the pictures of expression ``index``: coloured with its legend, then its bare poses."""
    shared = stage.result()
    rig, posed = shared.rig, shared.poses[index]
    colours = np.asarray([entry[2] for entry in legend]).reshape(len(legend), 3)
    fills = triangle_colours(
        rig.triangles, shared.active[rig.indices([entry[1] for entry in legend])], colours
    )
    words = [entry[0] + (" (again)" if entry[3] else "") for entry in legend]
    motion = Motion.of(posed, rig.neutral, rig.triangles, shared.normals, shared.twins)
    names = [entry[1] for entry in legend]
    backdrops = {key: view.result() for key, view in views.items()}
    rasters = {key: backdrop.pose(posed, motion) for key, backdrop in backdrops.items()}
    arrows = {
        key: gaze_arrows(rig, names, shared.active, shared.normals, posed, backdrop.frame)
        for key, backdrop in backdrops.items()
    }
    painted = _legend_picture(
        rasters["front_pose"].over(fills, BACKGROUND), words, colours, arrows["front_pose"]
    )
    return [
        (PAINTED, painted),
        *((key, _pose_picture(raster, arrows[key])) for key, raster in rasters.items()),
    ]


def _pose_picture(raster: Raster, arrows: Sequence[Arrow]) -> bytes:
    """The PNG of a bare pose in grey, with its gaze ``arrows``."""
    image = raster.over(CLAY, 1.0)
    if not arrows:
        return _png(image)
    from PIL import Image, ImageDraw

    picture = Image.fromarray(image)
    draw_arrows(ImageDraw.Draw(picture), arrows, 0, 255)
    return _png(picture)


def _processors() -> int:
    """Processors this process may run on, at most `_MOST_THREADS`."""
    found = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    return min(found, _MOST_THREADS)


def _legend_picture(
    face: np.ndarray, legend: Sequence[str], colours: np.ndarray, arrows: Sequence[Arrow]
) -> bytes:
    """The PNG of `SIZE`: the RGB ``face`` (with its gaze ``arrows``) on the left, the legend (a swatch and
    the words per entry, `legend_layout`) on its right."""
    from PIL import Image, ImageDraw

    width, height = SIZE
    left = face.shape[1]
    canvas = np.empty((height, width, 3), dtype=np.uint8)
    canvas[:] = np.round(255 * BACKGROUND).astype(np.uint8)
    canvas[:, :left] = face
    image = Image.fromarray(canvas)
    draw = ImageDraw.Draw(image)
    draw_arrows(draw, arrows, (0, 0, 0), (255, 255, 255))
    pixels, entries = legend_layout(legend, left)
    font = _font(pixels, threading.get_ident())
    for (swatch, lines), colour in zip(
        entries, np.asarray(colours, dtype=np.float64).reshape(-1, 3), strict=True
    ):
        draw.rectangle(swatch, fill=tuple(int(round(255 * value)) for value in colour))
        for text, (x, y, _, _) in lines:
            draw.text((x, y), text, fill=(0, 0, 0), font=font)
    return _png(image)


#: A legend entry as drawn: its swatch (x0, y0, x1, y1) and its lines, each with its text's box.
LegendEntry = tuple[tuple[int, int, int, int], list[tuple[str, tuple[int, int, int, int]]]]


def legend_layout(legend: Sequence[str], left: int) -> tuple[int, list[LegendEntry]]:
    """Where the legend of a coloured picture goes, right of ``left`` in `SIZE`: the text size in pixels and
    per entry its swatch and lines (with the box of each line's text), centred vertically.

    The largest text (`_LEGEND_PX` down to `_SMALLEST_PX`) whose entries, wrapped at word breaks onto at
    most three lines, fit the picture; when none does, each entry on one line, cut with an ellipsis, at the
    largest size whose lines fit (the smallest at worst).
    """
    from PIL import Image, ImageDraw

    draw = ImageDraw.Draw(Image.new("L", (1, 1)))
    width, height = SIZE
    sizes = range(_LEGEND_PX, _SMALLEST_PX - 1, -1)
    for most, pixels in [(3, size) for size in sizes] + [(1, size) for size in sizes]:
        font = _font(pixels, threading.get_ident())
        line, swatch = round(1.3 * pixels), round(0.8 * pixels)
        x = left + 4
        room = width - (x + swatch + 4) - 3
        wrapped = [_wrapped(draw, words, font, room, most) for words in legend]
        gap = round(0.35 * pixels)
        total = sum(len(lines) for lines in wrapped) * line + gap * max(len(legend) - 1, 0)
        if total <= 0.96 * height or (most == 1 and pixels == _SMALLEST_PX):
            break
    entries: list[LegendEntry] = []
    y = round((height - total) / 2)
    for lines in wrapped:
        swatch_box = (x, y + (line - swatch) // 2, x + swatch - 1, y + (line + swatch) // 2 - 1)
        placed = []
        for text in lines:
            top = y + line // 2
            box = draw.textbbox((x + swatch + 4, top), text, font=font, anchor="lm")
            placed.append((text, tuple(int(v) for v in box)))
            y += line
        entries.append((swatch_box, placed))
        y += gap
    return pixels, entries


def _wrapped(
    draw: ImageDraw.ImageDraw, words: str, font: ImageFont.FreeTypeFont, room: int, most: int
) -> list[str]:
    """``words`` in lines of at most ``room`` pixels, broken between words: at most ``most`` lines, the
    last cut with an ellipsis when they do not hold them all."""
    lines: list[str] = []
    for word in words.split():
        if lines and draw.textlength(f"{lines[-1]} {word}", font=font) <= room:
            lines[-1] += f" {word}"
        else:
            lines.append(word)
    if len(lines) > most:
        lines = [*lines[: most - 1], " ".join(lines[most - 1 :])]
    return [*lines[:-1], _fitted(draw, lines[-1], font, room)] if lines else [""]


def _png(image: np.ndarray | Image.Image) -> bytes:
    """PNG bytes of an RGB or grey image, without a timestamp or software tag (the same image, the same
    bytes)."""
    from PIL import Image

    if isinstance(image, np.ndarray):
        image = Image.fromarray(image)
    buffer = io.BytesIO()
    image.save(buffer, format="PNG", compress_level=_PNG_LEVEL, compress_type=_PNG_STRATEGY)
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
