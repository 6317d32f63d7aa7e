"""Pictures of expressions: a z-buffered, smoothly shaded render with the active shapes coloured.

An expression is the template posed in it (neutral plus the sum of its blendshapes, Carrigan et al. 2020,
sec. 3) and seen through a camera such as `rigs.frontal_camera`. A triangle takes the colour of the
expression's shape most of its corners are active in (eq. 2, with the masks packing used:
`active_vertices`), and a legend names every shape with its colour; no colour repeats within an
expression (`shape_colours`).

`render_mesh` is the one renderer: a scanline rasteriser in numpy with a depth buffer (nearest surface
wins, exactly, also where triangles cross), Gouraud-shaded by a two-sided Lambert light and supersampled
for smooth edges. The session pictures (`picture`, with a title and a legend drawn by Pillow) and the
report's contact sheets (`reports.contact_sheet`) both use it.
"""

from __future__ import annotations

import colorsys
import importlib.util
import io
from collections.abc import Sequence
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from PIL import Image, ImageDraw, ImageFont

    from rigs import Rig

#: matplotlib's ``tab20`` colours (ten hues, a dark and a light tone each), without importing matplotlib.
_TAB20 = (
    np.array(
        [
            [int(code[i : i + 2], 16) for i in (0, 2, 4)]
            for code in "1f77b4 aec7e8 ff7f0e ffbb78 2ca02c 98df8a d62728 ff9896 9467bd c5b0d5 8c564b c49c94 "
            "e377c2 f7b6d2 7f7f7f c7c7c7 bcbd22 dbdb8d 17becf 9edae5".split()
        ]
    )
    / 255.0
)
#: Picture size in pixels (width, height).
SIZE = (420, 400)
SKIN = np.array([0.86, 0.84, 0.82])
BACKGROUND = np.array([1.0, 1.0, 1.0])
#: Share of a picture's width the face takes when it has a legend (the legend is on its right).
FACE_SHARE = 0.62
#: Share of a picture's height the face takes when it has a title (the title is above it).
TITLE_SHARE = 0.92
#: Light direction in camera coordinates (from the upper left, towards the face).
_LIGHT = np.array([-0.35, 0.45, 1.0]) / np.linalg.norm([-0.35, 0.45, 1.0])
_AMBIENT, _DIFFUSE = 0.3, 0.7
#: Samples per pixel along each axis (the image is rendered this much larger and averaged down).
SUPERSAMPLE = 2
#: Largest number of pixel samples rasterised at once (about 100 MB of temporaries): bounds the memory
#: of meshes with many large, overlapping triangles.
_CHUNK_SAMPLES = 2_000_000
#: zlib level of the PNG pictures: level 1 writes them about four times as fast as the default 6, for
#: files about a third larger.
_PNG_LEVEL = 1
#: Title and legend text heights in pixels; the legend shrinks down to the smallest to fit its lines.
_TITLE_PX, _LEGEND_PX, _SMALLEST_PX = 13, 11, 6


def shape_colours(groups: Sequence[int]) -> np.ndarray:
    """Distinct RGB colours for the shapes of an expression, given as groups of 1 or 2 (symmetry pairs).

    Up to ten groups take the hues of matplotlib's ``tab20``: the dark and the light tone of one hue for
    the two shapes of a pair, the dark tone for a shape alone, so a pair looks related and no colour
    repeats. More shapes take evenly spaced hues.

    Parameters
    ----------
    groups : sequence of int
        Number of shapes in each group, in legend order.

    Returns
    -------
    (sum(groups), 3) array.
    """
    if len(groups) <= len(_TAB20) // 2 and all(size in (1, 2) for size in groups):
        return np.asarray([_TAB20[2 * hue + tone] for hue, size in enumerate(groups) for tone in range(size)])
    count = int(sum(groups))
    hues = np.arange(count) / max(count, 1)
    return np.asarray([colorsys.hsv_to_rgb(hue, 1.0, 0.85) for hue in hues]).reshape(count, 3)


def active_vertices(rig: Rig, mu: float = 0.3) -> np.ndarray:
    """The binary blendshapes (eq. 2) exactly as `packing.analyse` makes them for packing.

    The noise floor is packing's (`packing.PackingParams.noise_floor`), relative to the rig's
    bounding-box diagonal, so a shape packing treats as empty has no coloured vertex either.

    Parameters
    ----------
    rig : rigs.Rig
    mu : float in (0, 1]
        The threshold the expressions were packed with.

    Returns
    -------
    (K, N) bool array.
    """
    from packing import PackingParams, binary_blendshapes

    floor = PackingParams(mu=mu).noise_floor
    return np.asarray(binary_blendshapes(rig.deltas, mu, noise_floor=floor, scale=rig.diagonal()))


def triangle_colours(triangles: np.ndarray, active: np.ndarray, colours: np.ndarray) -> np.ndarray:
    """The colour of each triangle: that of the shape most of its corners are active in, else skin.

    Parameters
    ----------
    triangles : (T, 3) int array
    active : (S, N) bool array
        Active vertices (eq. 2) of each of the expression's shapes.
    colours : (S, 3) array
        The colour of each shape (`shape_colours`); ties go to the first shape.

    Returns
    -------
    (T, 3) float array.
    """
    if not len(active):
        return np.repeat(SKIN[None], len(triangles), axis=0)
    palette = np.vstack([np.asarray(colours, dtype=np.float64).reshape(len(active), 3), SKIN])
    corners = np.asarray(active)[:, triangles].sum(axis=2)  # (S, T)
    labels = np.where(corners.max(axis=0) > 0, corners.argmax(axis=0), -1)  # -1 picks the skin row
    return palette[labels]


def render_mesh(
    vertices: np.ndarray,
    triangles: np.ndarray,
    camera: np.ndarray,
    colours: np.ndarray,
    *,
    width: int,
    height: int,
    margin: float = 0.03,
    supersample: int = SUPERSAMPLE,
) -> np.ndarray:
    """An RGBA image of a mesh seen through an orthographic camera, fitted and centred in the image.

    Parameters
    ----------
    vertices : (N, 3) array
        Positions (posed).
    triangles : (T, 3) int array
    camera : (3, 3) array
        Rows right, up and towards the viewer (`rigs.frontal_camera`).
    colours : (T, 3) array
        RGB in [0, 1] of each triangle (`triangle_colours`), shaded by the light.
    width, height : int
        Image size in pixels; the mesh's projection fills it less ``margin`` on every side.
    margin : float
        Share of the image's larger side left free around the mesh.
    supersample : int
        Samples per pixel along each axis.

    Returns
    -------
    (height, width, 4) uint8 array: RGB (not premultiplied) and alpha, the share of the pixel the mesh
    covers (0 where it covers none).

    Notes
    -----
    The nearest surface wins at every sample (a depth buffer), so the picture is right where triangles
    cross or a mesh folds over itself, unlike the painter's algorithm. Lighting is two-sided, since the
    orientation of a rig's mesh is unknown. O(T + P) for P covered samples (pixels times supersample
    squared times overdraw), in numpy; the same input gives the same image.
    """
    view = np.asarray(vertices, dtype=np.float64) @ np.asarray(camera, dtype=np.float64).T
    triangles = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    big = (width * supersample, height * supersample)
    points = _fit(view, big, margin)
    depth_plane, shade_plane = _planes(points, triangles, _vertex_brightness(view, triangles))
    nearest = _rasterise(points, triangles, depth_plane, big).reshape(big[1], big[0])
    return _downsample(*_shade(nearest, shade_plane, colours), supersample)


def _fit(view: np.ndarray, size: tuple[int, int], margin: float) -> np.ndarray:
    """Camera coordinates to pixel coordinates (x right, y down, z nearness), fitted and centred."""
    low, high = view[:, :2].min(axis=0), view[:, :2].max(axis=0)
    extent = np.maximum(high - low, 1e-300)
    room = np.array(size, dtype=np.float64) - 2.0 * margin * max(size)
    scale = float(np.min(np.maximum(room, 1.0) / extent))
    centre = (low + high) / 2.0
    x = (view[:, 0] - centre[0]) * scale + size[0] / 2.0
    y = (centre[1] - view[:, 1]) * scale + size[1] / 2.0
    return np.stack([x, y, view[:, 2]], axis=1)


def _vertex_brightness(view: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Two-sided Lambert brightness of each vertex from its area-weighted normal."""
    corners = view[triangles]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    corner_normals = np.repeat(normals, 3, axis=0)
    summed = np.stack(
        [np.bincount(triangles.ravel(), corner_normals[:, d], minlength=len(view)) for d in range(3)], axis=1
    ).astype(np.float64)  # (float even without triangles)
    lengths = np.linalg.norm(summed, axis=1, keepdims=True)
    unit = np.divide(summed, lengths, out=np.zeros_like(summed), where=lengths > 0)
    return _AMBIENT + _DIFFUSE * np.abs(unit @ _LIGHT)


def _planes(
    points: np.ndarray, triangles: np.ndarray, brightness: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Per triangle, depth and brightness as planes ``a x + b y + c`` over the image (orthographic
    projection keeps both affine across a triangle); NaN rows for triangles of no area in the image."""
    corners = points[triangles]
    x, y = corners[..., 0], corners[..., 1]
    following, last = [1, 2, 0], [2, 0, 1]
    a = y[:, following] - y[:, last]  # barycentric coordinate i = (a_i x + b_i y + c_i) / area
    b = x[:, last] - x[:, following]
    c = x[:, following] * y[:, last] - x[:, last] * y[:, following]
    area = c.sum(axis=1)
    flat = np.abs(area) <= 1e-9
    scale = np.where(flat, np.nan, 1.0 / np.where(flat, 1.0, area))[:, None]
    weights = np.stack([a, b, c], axis=1) * scale[:, :, None]  # (T, 3 coefficients, 3 corners)
    depth = np.einsum("tkc,tc->tk", weights, corners[..., 2])
    shade = np.einsum("tkc,tc->tk", weights, brightness[triangles])
    return depth, shade


def _rasterise(
    points: np.ndarray, triangles: np.ndarray, depth_plane: np.ndarray, size: tuple[int, int]
) -> np.ndarray:
    """(width * height,) index of the nearest triangle at each pixel centre, -1 where none.

    Triangles are cut into rows of pixel centres and rows into spans (scanline conversion, all in
    numpy), in chunks of at most `_CHUNK_SAMPLES` samples; a centre on a shared edge belongs to both
    triangles. The nearest sample wins; between equally near ones, the triangle of the larger index.
    """
    width, height = size
    edges = _edges(points[triangles])
    low = np.maximum(np.ceil(edges[:, [0, 6]] - 0.5), 0).astype(np.int64)  # first column and row
    high = np.minimum(np.floor(edges[:, [1, 8]] - 0.5), [width - 1, height - 1]).astype(np.int64)
    spans = np.maximum(high - low + 1, 0)
    bound = np.where(np.isnan(depth_plane[:, 0]), 0, spans[:, 0] * spans[:, 1])
    nearest = np.full(width * height, -1, dtype=np.int32)
    depth = np.full(width * height, -np.inf)
    start, ends = 0, np.cumsum(bound)
    while start < len(triangles):
        stop = max(
            int(np.searchsorted(ends, ends[start] - bound[start] + _CHUNK_SAMPLES, "right")), start + 1
        )
        chunk = np.arange(start, stop, dtype=np.int32)[bound[start:stop] > 0]
        pixel, owner, near = _samples(edges[chunk], chunk, low[chunk, 1], spans[chunk, 1], depth_plane, width)
        _keep_nearest(nearest, depth, pixel, owner, near)
        start = stop
    return nearest


def _edges(corners: np.ndarray) -> np.ndarray:
    """Per triangle: its x range, the top corner and the slope (dx/dy) of the edge from it to the bottom
    corner, the middle corner and the slopes of the edges from top to middle and middle to bottom, and
    the bottom row: ``x_min, x_max, x_top, slope_long, x_mid, slope_upper, y_top, y_mid, y_bottom,
    slope_lower`` (slopes of horizontal edges are 0: no row crosses them)."""
    order = np.argsort(corners[:, :, 1], axis=1, kind="stable")
    top, mid, bottom = (
        np.take_along_axis(corners[:, :, :2], order[:, [i], None], axis=1)[:, 0] for i in range(3)
    )

    def slope(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        rise = b[:, 1] - a[:, 1]
        return np.divide(b[:, 0] - a[:, 0], rise, out=np.zeros(len(a)), where=rise != 0)

    return np.stack(
        [
            corners[:, :, 0].min(axis=1),
            corners[:, :, 0].max(axis=1),
            top[:, 0],
            slope(top, bottom),
            mid[:, 0],
            slope(top, mid),
            top[:, 1],
            mid[:, 1],
            bottom[:, 1],
            slope(mid, bottom),
        ],
        axis=1,
    )


def _samples(
    edges: np.ndarray,
    owners: np.ndarray,
    first_row: np.ndarray,
    rows: np.ndarray,
    depth_plane: np.ndarray,
    width: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pixel index, triangle and depth of every pixel centre inside the given triangles (`_edges`).

    Work is per row of a triangle where it can be (its span, its first pixel and depth, the depth step
    along the row), and one ``np.repeat`` per value expands the rows to their pixels.
    """
    row_of = np.repeat(np.arange(len(owners), dtype=np.int32), rows)
    y = first_row.astype(np.int32)[row_of] + _ragged(rows)
    edge = np.take(edges, row_of, axis=0)
    centre = y + 0.5
    long_side = edge[:, 2] + (centre - edge[:, 6]) * edge[:, 3]
    upper = centre < edge[:, 7]
    short_side = np.where(
        upper,
        edge[:, 2] + (centre - edge[:, 6]) * edge[:, 5],
        edge[:, 4] + (centre - edge[:, 7]) * edge[:, 9],
    )
    left = np.clip(np.minimum(long_side, short_side), edge[:, 0], edge[:, 1])  # (rounding at the corners)
    right = np.clip(np.maximum(long_side, short_side), edge[:, 0], edge[:, 1])
    start = np.maximum(np.ceil(left - 0.5), 0).astype(np.int32)
    count = np.maximum(np.minimum(np.floor(right - 0.5), width - 1).astype(np.int32) - start + 1, 0)
    owner = owners[row_of]
    plane = np.take(depth_plane, owner, axis=0)
    step = plane[:, 0]
    first_depth = step * (start + 0.5) + plane[:, 1] * centre + plane[:, 2]
    offset = _ragged(count)
    pixel = np.repeat(y * width + start, count) + offset
    near = np.repeat(first_depth, count) + np.repeat(step, count) * offset
    return pixel, np.repeat(owner, count), near


def _ragged(counts: np.ndarray) -> np.ndarray:
    """0, 1, ..., counts[0] - 1, 0, 1, ..., counts[1] - 1, ... (one arange per entry, concatenated), as
    int32 (a chunk holds far fewer than 2**31 samples)."""
    starts = np.cumsum(counts, dtype=np.int32) - counts
    return np.arange(starts[-1] + counts[-1] if len(counts) else 0, dtype=np.int32) - np.repeat(
        starts, counts
    )


def _keep_nearest(
    nearest: np.ndarray, depth: np.ndarray, pixel: np.ndarray, owner: np.ndarray, near: np.ndarray
) -> None:
    """Merge samples into the buffers: the nearest sample per pixel, the larger triangle on a tie."""
    before = depth[pixel]
    np.maximum.at(depth, pixel, near)
    nearest[pixel[depth[pixel] > before]] = -1  # a nearer sample came: the earlier owner loses
    front = near >= depth[pixel]
    np.maximum.at(nearest, pixel[front], owner[front])


def _shade(
    nearest: np.ndarray, shade_plane: np.ndarray, colours: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Shaded RGB (0 where no triangle is) and coverage (0 or 1) of every sample of the image
    ``nearest`` (the triangle at each sample, -1 for none), in float32."""
    blank = np.zeros((1, 3), dtype=np.float32)  # row -1: what samples without a triangle take
    planes = np.vstack([np.asarray(shade_plane, dtype=np.float32), blank])
    table = np.vstack([np.asarray(colours, dtype=np.float32).reshape(-1, 3), blank])
    x = np.arange(nearest.shape[1], dtype=np.float32) + 0.5
    y = np.arange(nearest.shape[0], dtype=np.float32)[:, None] + 0.5
    light = np.take(planes[:, 0], nearest) * x + np.take(planes[:, 1], nearest) * y
    light += np.take(planes[:, 2], nearest)
    rgb = np.stack([np.take(table[:, channel], nearest) * light for channel in range(3)], axis=2)
    return rgb, (nearest >= 0).astype(np.float32)


def _downsample(rgb: np.ndarray, coverage: np.ndarray, factor: int) -> np.ndarray:
    """The uint8 RGBA image of ``factor`` x ``factor`` blocks of samples: straight RGB averaged over a
    block's covered samples, alpha the share of them covered."""
    blocks = [(row, column) for row in range(factor) for column in range(factor)]
    colour = sum(rgb[row::factor, column::factor] for row, column in blocks)
    covered = sum(coverage[row::factor, column::factor] for row, column in blocks)[..., None]
    straight = np.divide(colour, covered, out=np.zeros_like(colour), where=covered > 0)
    image = np.concatenate([np.clip(straight, 0.0, 1.0), covered / factor**2], axis=2)
    return (image * 255.0 + 0.5).astype(np.uint8)


def picture(
    vertices: np.ndarray,
    triangles: np.ndarray,
    camera: np.ndarray,
    colours: np.ndarray,
    legend: Sequence[str],
    legend_colours: np.ndarray,
    *,
    title: str = "",
    size: tuple[int, int] = SIZE,
) -> bytes:
    """A PNG of the mesh (`render_mesh`) with a title above and a legend on its right.

    Parameters
    ----------
    vertices : (N, 3) array
        Posed positions.
    triangles : (T, 3) int array
    camera : (3, 3) array
        Rows right, up, towards the viewer.
    colours : (T, 3) array
        The colour of each triangle (`triangle_colours`).
    legend : sequence of str
        One entry per shape, in plain words.
    legend_colours : (len(legend), 3) array
        The colour of each legend entry.
    title : str
    size : (width, height) in pixels

    Returns
    -------
    bytes of a PNG image (no timestamp or software tag: the same input gives the same bytes). The face
    fills the left `FACE_SHARE` of the width (all of it without a legend) and the lower `TITLE_SHARE`
    of the height (all of it without a title), centred there.
    """
    from PIL import Image

    width, height = size
    face_width = round(FACE_SHARE * width) if len(legend) else width
    top = height - round(TITLE_SHARE * height) if title else 0
    face = render_mesh(vertices, triangles, camera, colours, width=face_width, height=height - top)
    canvas = np.empty((height, width, 3), dtype=np.uint8)
    canvas[:] = np.round(255 * BACKGROUND).astype(np.uint8)
    canvas[top:, :face_width] = _over(face, canvas[top:, :face_width])
    image = Image.fromarray(canvas, "RGB")
    _draw_text(image, title, legend, np.asarray(legend_colours, dtype=np.float64).reshape(-1, 3), face_width)
    buffer = io.BytesIO()
    image.save(buffer, format="PNG", compress_level=_PNG_LEVEL)
    return buffer.getvalue()


def _over(image: np.ndarray, background: np.ndarray) -> np.ndarray:
    """RGBA ``image`` (uint8) composited over RGB ``background`` (uint8)."""
    alpha = image[..., 3:].astype(np.float32) / 255.0
    mixed = image[..., :3] * alpha + background * (1.0 - alpha)
    return np.round(mixed).astype(np.uint8)


def _draw_text(image: Image.Image, title: str, legend: Sequence[str], colours: np.ndarray, left: int) -> None:
    """The title at the top left; the legend (a swatch and the words per line) right of ``left``,
    centred vertically, its text shrunk to fit the height and cut to fit the width."""
    from PIL import ImageDraw

    draw = ImageDraw.Draw(image)
    width, height = image.size
    if title:
        draw.text((round(0.02 * width), round(0.01 * height)), title, fill=(0, 0, 0), font=_font(_TITLE_PX))
    if not len(legend):
        return
    pixels = _LEGEND_PX
    while pixels > _SMALLEST_PX and len(legend) * round(1.3 * pixels) > 0.96 * height:
        pixels -= 1
    font, line = _font(pixels), round(1.3 * pixels)
    swatch = round(0.8 * pixels)
    x, y = left + 4, round((height - len(legend) * line) / 2)
    room = width - (x + swatch + 4) - 2
    for words, colour in zip(legend, colours, strict=True):
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


def _fitted(draw: ImageDraw.ImageDraw, words: str, font: ImageFont.FreeTypeFont, room: int) -> str:
    """``words``, cut and ended with an ellipsis when wider than ``room`` pixels."""
    if draw.textlength(words, font=font) <= room:
        return words
    while words and draw.textlength(words + "\u2026", font=font) > room:
        words = words[:-1]
    return words.rstrip() + "\u2026"


@lru_cache(maxsize=8)
def _font(pixels: int) -> ImageFont.FreeTypeFont:
    """DejaVu Sans at ``pixels``: the font matplotlib ships (so every machine draws the same glyphs), found
    in its package data without importing it."""
    from PIL import ImageFont

    package = Path(str(importlib.util.find_spec("matplotlib").origin)).parent
    return ImageFont.truetype(str(package / "mpl-data" / "fonts" / "ttf" / "DejaVuSans.ttf"), pixels)
