"""Pictures of the expressions of a scanning session: shaded renders with the active shapes coloured.

Each picture is the template posed in one expression (neutral plus the sum of its blendshapes, Carrigan et
al. 2020, sec. 3) seen through a camera (`harness._session_camera`), drawn by the painter's algorithm:
the triangles sorted far to near and filled as one matplotlib ``PolyCollection`` on the Agg canvas, each
Lambert-shaded. A triangle takes the colour of the expression's shape most of its corners are active in
(eq. 2), and a legend names every shape with its colour; no colour repeats within an expression.
"""

from __future__ import annotations

import io
from collections.abc import Sequence

import numpy as np
from matplotlib import colormaps
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import PolyCollection
from matplotlib.figure import Figure
from matplotlib.patches import Patch

#: Picture size in inches (at 100 dpi).
SIZE = (4.2, 4.0)
SKIN = np.array([0.86, 0.84, 0.82])
BACKGROUND = "white"
#: Share of a picture's width the face takes when it has a legend (the legend is on its right).
FACE_SHARE = 0.62
#: Share of a picture's height the face takes when it has a title (the title is above it).
TITLE_SHARE = 0.92
#: Light direction in camera coordinates (from the upper left, towards the face).
_LIGHT = np.array([-0.35, 0.45, 1.0]) / np.linalg.norm([-0.35, 0.45, 1.0])


def shape_colours(groups: Sequence[int]) -> np.ndarray:
    """Distinct RGB colours for the shapes of an expression, given as groups of 1 or 2 (symmetry pairs).

    Up to ten groups take the hues of ``tab20``: the dark and the light tone of one hue for the two
    shapes of a pair, the dark tone for a shape alone, so a pair looks related and no colour repeats.
    More shapes take evenly spaced hues.

    Parameters
    ----------
    groups : sequence of int
        Number of shapes in each group, in legend order.

    Returns
    -------
    (sum(groups), 3) array.
    """
    table = np.asarray(colormaps["tab20"].colors)[:, :3]
    if len(groups) <= len(table) // 2 and all(size in (1, 2) for size in groups):
        return np.asarray([table[2 * hue + tone] for hue, size in enumerate(groups) for tone in range(size)])
    count = int(sum(groups))
    return 0.85 * colormaps["hsv"](np.linspace(0.0, 1.0, count, endpoint=False))[:, :3].reshape(count, 3)


def triangle_labels(triangles: np.ndarray, active: np.ndarray) -> np.ndarray:
    """For each triangle, the index of the shape most of its corners are active in, or -1.

    Parameters
    ----------
    triangles : (T, 3) int array
    active : (S, N) bool array
        Active vertices (eq. 2) of each of the expression's shapes.
    """
    if not len(active):
        return np.full(len(triangles), -1)
    corners = active[:, triangles].sum(axis=2)  # (S, T)
    return np.where(corners.max(axis=0) > 0, corners.argmax(axis=0), -1)


def render(
    vertices: np.ndarray,
    triangles: np.ndarray,
    camera: np.ndarray,
    labels: np.ndarray,
    legend: Sequence[str],
    colours: np.ndarray,
    *,
    title: str = "",
    size: tuple[float, float] = SIZE,
    dpi: int = 100,
) -> bytes:
    """A PNG of the mesh seen through ``camera``, triangles coloured by ``labels``, with a legend.

    Parameters
    ----------
    vertices : (N, 3) array
        Posed positions.
    triangles : (T, 3) int array
    camera : (3, 3) array
        Rows right, up, towards the viewer (orthographic).
    labels : (T,) int array
        Index into ``legend`` of each triangle's shape, -1 for skin.
    legend : sequence of str
        One entry per shape.
    colours : (len(legend), 3) array
        The colour of each shape (`shape_colours`).
    title : str
    size : (width, height) in inches
    dpi : int

    Returns
    -------
    bytes of a PNG image (no timestamp or software tag: the same input gives the same bytes).

    Notes
    -----
    O(T log T) for the depth sort; a 60k-triangle mesh draws in about a second.
    """
    view = np.asarray(vertices, dtype=np.float64) @ np.asarray(camera, dtype=np.float64).T
    corners = view[triangles]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    lengths = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = np.divide(normals, lengths, out=np.zeros_like(normals), where=lengths > 0)
    brightness = 0.3 + 0.7 * np.abs(normals @ _LIGHT)  # two-sided: the mesh's orientation is unknown
    colours = np.asarray(colours, dtype=np.float64).reshape(len(legend), 3)
    palette = np.vstack([colours, SKIN]) if len(legend) else SKIN[None]
    fill = np.clip(palette[labels] * brightness[:, None], 0.0, 1.0)
    order = np.argsort(corners[:, :, 2].mean(axis=1), kind="stable")  # far first: nearer ones paint over
    figure = Figure(figsize=size, dpi=dpi, facecolor=BACKGROUND)
    FigureCanvasAgg(figure)
    has_legend = len(legend) > 0
    ax = figure.add_axes((0.0, 0.0, FACE_SHARE if has_legend else 1.0, TITLE_SHARE if title else 1.0))
    ax.add_collection(
        PolyCollection(corners[order, :, :2], facecolors=fill[order], edgecolors=fill[order], linewidths=0.25)
    )
    low, high = view[:, :2].min(axis=0), view[:, :2].max(axis=0)
    margin = 0.03 * float(np.max(high - low))
    ax.set_xlim(low[0] - margin, high[0] + margin)
    ax.set_ylim(low[1] - margin, high[1] + margin)
    ax.set_aspect("equal", adjustable="box")
    ax.set_axis_off()
    if title:
        figure.text(0.02, 0.97, title, fontsize=9, va="top", ha="left")
    if has_legend:
        handles = [Patch(facecolor=colour, edgecolor="none") for colour in colours]
        figure.legend(
            handles,
            list(legend),
            loc="center left",
            bbox_to_anchor=(FACE_SHARE, 0.5),
            fontsize=6.5,
            frameon=False,
            handlelength=1.0,
            borderaxespad=0.2,
        )
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", facecolor=BACKGROUND, metadata={"Software": None})
    return buffer.getvalue()
