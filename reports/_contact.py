"""Expression contact sheets: each reference expression drawn as a shaded face, its shapes coloured.

An artist takes these to a scanning session (Carrigan et al. 2020, sec. 5.3 and Fig. 11): every panel shows
the template posed in one expression (neutral plus the sum of its blendshapes, sec. 3), the active vertices
of each blendshape (eq. 2) in that shape's colour, and the shape names underneath.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from packing import binary_blendshapes
from reports._png import report_style
from rigs import Rig

_SKIN = np.array([0.86, 0.84, 0.82])
_SHAPE_COLOURS = np.array(
    [
        (0.12, 0.47, 0.71),
        (1.00, 0.50, 0.05),
        (0.17, 0.63, 0.17),
        (0.84, 0.15, 0.16),
        (0.58, 0.40, 0.74),
        (0.55, 0.34, 0.29),
        (0.89, 0.47, 0.76),
        (0.74, 0.74, 0.13),
        (0.09, 0.75, 0.81),
        (0.35, 0.35, 0.35),
        (0.00, 0.30, 0.55),
        (0.65, 0.30, 0.00),
    ]
)
_LIGHT = np.array([-0.3, 0.4, 1.0]) / np.linalg.norm([-0.3, 0.4, 1.0])  # in camera coordinates


def camera_basis(rig: Rig) -> np.ndarray:
    """Orthonormal rows (right, up, towards the viewer) for a front view of the rig's neutral.

    The viewing direction is the area-weighted mean triangle normal, which points out of an open face
    mesh; a closed mesh (mean normal near zero) is viewed along +z. "Up" is the world y axis made
    orthogonal to the viewing direction.
    """
    a, b, c = (rig.neutral[rig.triangles[:, i]] for i in range(3))
    doubled_normals = np.cross(b - a, c - a)
    towards_viewer = doubled_normals.sum(axis=0)
    total_area = np.linalg.norm(doubled_normals, axis=1).sum()
    if np.linalg.norm(towards_viewer) <= 0.1 * total_area:
        towards_viewer = np.array([0.0, 0.0, 1.0])
    towards_viewer = towards_viewer / np.linalg.norm(towards_viewer)
    up = np.array([0.0, 1.0, 0.0])
    if abs(up @ towards_viewer) > 0.99:
        up = np.array([0.0, 0.0, 1.0])
    up = up - (up @ towards_viewer) * towards_viewer
    up /= np.linalg.norm(up)
    return np.stack([np.cross(up, towards_viewer), up, towards_viewer])


def shaded_colours(
    rig: Rig, view: np.ndarray, indices: np.ndarray, active: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Lambert-shaded RGB of every triangle, and the colour of each shape of the expression.

    Parameters
    ----------
    rig : Rig
    view : (N, 3) array
        Posed vertex positions in camera coordinates (right, up, towards the viewer).
    indices : (K_e,) int array
        The expression's shapes; the i-th gets the i-th shape colour.
    active : (K, N) bool array
        Active vertices of every shape (eq. 2). A triangle takes the colour of a shape when any of its
        vertices is active in it (the first such shape of the expression).

    Returns
    -------
    (T, 3) triangle colours and (K_e, 3) shape colours.
    """
    corners = view[rig.triangles]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    lengths = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = np.divide(normals, lengths, out=np.zeros_like(normals), where=lengths > 0)
    brightness = 0.35 + 0.65 * np.abs(normals @ _LIGHT)  # two-sided: orientation of the mesh is unknown

    colours = _SHAPE_COLOURS[np.arange(len(indices)) % len(_SHAPE_COLOURS)]
    label = np.where(active[indices].any(axis=0), active[indices].argmax(axis=0), -1)
    triangle_label = label[rig.triangles].max(axis=1)
    palette = np.vstack([colours, _SKIN])  # label -1 picks the last row
    return palette[triangle_label] * brightness[:, None], colours


def rasterize(corners: np.ndarray, colours: np.ndarray, height: int, width: int) -> np.ndarray:
    """Z-buffered RGBA image of triangles given in pixel coordinates.

    Parameters
    ----------
    corners : (T, 3, 3) float array
        Triangle corners as (column, row, depth); larger depth is nearer to the viewer.
    colours : (T, 3) float array
        RGB of each triangle.
    height, width : int
        Image size in pixels.

    Returns
    -------
    (height, width, 4) float array; alpha is 0 where no triangle covers a pixel.

    Notes
    -----
    Each triangle is sampled on a barycentric grid fine enough that neighbouring samples are at most one
    pixel apart (its longest edge in pixels sets the grid), so covered pixels have no holes; per pixel the
    nearest sample wins (a sort, no loop over triangles). O(S log S) for S samples, about the covered area
    times the overdraw.
    """
    edges = np.linalg.norm(corners[:, [1, 2, 0], :2] - corners[:, :, :2], axis=2).max(axis=1)
    steps = np.maximum(np.ceil(np.nan_to_num(edges, nan=0.0)).astype(np.int64), 1)
    columns, rows, depths, owners = [], [], [], []
    for step in np.unique(steps):
        selected = np.flatnonzero(steps == step)
        i, j = np.meshgrid(np.arange(step + 1), np.arange(step + 1), indexing="ij")
        inside = i + j <= step
        weights = np.stack([i[inside], j[inside], step - i[inside] - j[inside]], axis=1) / step
        samples = np.einsum("sk,tkd->tsd", weights, corners[selected])
        columns.append(samples[..., 0].ravel())
        rows.append(samples[..., 1].ravel())
        depths.append(samples[..., 2].ravel())
        owners.append(np.repeat(selected, len(weights)))
    column = np.floor(np.concatenate(columns)).astype(np.int64)
    row = np.floor(np.concatenate(rows)).astype(np.int64)
    depth, owner = np.concatenate(depths), np.concatenate(owners)
    keep = (column >= 0) & (column < width) & (row >= 0) & (row < height)
    pixel, depth, owner = row[keep] * width + column[keep], depth[keep], owner[keep]
    nearness = (depth - depth.min()) / max(np.ptp(depth), 1e-300)  # in [0, 1], 1 = nearest
    order = np.argsort(pixel + 0.5 * (1.0 - nearness), kind="stable")  # by pixel, nearest sample first
    pixel = pixel[order]
    first = np.flatnonzero(np.r_[True, pixel[1:] != pixel[:-1]])
    image = np.zeros((height * width, 4))
    image[pixel[first], :3] = colours[owner[order[first]]]
    image[pixel[first], 3] = 1.0
    return image.reshape(height, width, 4)


def draw_expression(
    ax: Axes, rig: Rig, shapes: Sequence[str], active: np.ndarray, camera: np.ndarray, *, width: int = 320
) -> np.ndarray:
    """Draw ``rig`` posed in the expression made of ``shapes`` onto ``ax`` as a shaded orthographic view.

    Parameters
    ----------
    ax : matplotlib Axes
        Target axes (their ticks and frame are switched off).
    rig : Rig
        The template rig.
    shapes : sequence of str
        Blendshape names of the expression; the i-th is drawn in the i-th shape colour.
    active : (K, N) bool array
        Active vertices of every blendshape of ``rig`` (eq. 2).
    camera : (3, 3) array
        Rows right, up and towards the viewer, as from `camera_basis`.
    width : int
        Width in pixels of the rendered image (drawn supersampled into the axes).

    Returns
    -------
    (len(shapes), 3) array of the RGB colours used for the shapes, in order.
    """
    indices = rig.indices(shapes)
    view = (rig.neutral + rig.deltas[indices].sum(axis=0)) @ camera.T
    colours, shape_colours = shaded_colours(rig, view, indices, active)
    low, high = view.min(axis=0), view.max(axis=0)
    scale = (width - 1) / max(high[0] - low[0], 1e-12)
    height = int(np.ceil((high[1] - low[1]) * scale)) + 1
    pixels = np.stack(
        [(view[:, 0] - low[0]) * scale, (high[1] - view[:, 1]) * scale, view[:, 2]], axis=1
    )  # image rows grow downwards
    ax.imshow(rasterize(pixels[rig.triangles], colours, height, width), interpolation="antialiased")
    ax.set_axis_off()
    return shape_colours


def _list_names(ax: Axes, shapes: Sequence[str], colours: np.ndarray, lines: int) -> None:
    ax.set_axis_off()
    line = 1.0 / lines
    for position, (name, colour) in enumerate(zip(shapes, colours, strict=True)):
        y = 1.0 - position * line
        ax.text(0.02, y, "\u25a0", color=colour, fontsize=8, va="top", transform=ax.transAxes)
        ax.text(0.14, y, name, fontsize=7, va="top", transform=ax.transAxes)


def distinct_sequences(sequences: Mapping[str, Sequence[Sequence[str]]]) -> dict[str, list[tuple[str, ...]]]:
    """Merge solvers with identical expressions (as sets of shapes) into one row labelled by all of them."""
    rows: dict[tuple[frozenset[str], ...], list[str]] = {}
    for solver, expressions in sequences.items():
        rows.setdefault(tuple(frozenset(e) for e in expressions), []).append(solver)
    return {", ".join(solvers): [tuple(e) for e in sequences[solvers[0]]] for solvers in rows.values()}


def contact_sheet(
    rig: Rig,
    sequences: Mapping[str, Sequence[Sequence[str]]],
    *,
    expressions: int = 5,
    mu: float = 0.3,
    title: str = "",
) -> Figure:
    """One row per distinct expression sequence, one panel per reference expression, shape names below.

    Parameters
    ----------
    rig : Rig
        The template rig the sequences were packed from.
    sequences : mapping solver name -> sequence of expressions (each a sequence of shape names)
        The solvers' expression sequences, in order. Solvers with identical expressions share a row.
    expressions : int
        How many of the first expressions to draw per row.
    mu : float
        Activity threshold of eq. 2 used to colour each shape's active vertices (the run's ``mu``).
    title : str
        Figure title, e.g. the rig name.

    Returns
    -------
    matplotlib Figure (not attached to pyplot; save it with `reports.png_bytes`).

    Raises
    ------
    ValueError
        When ``sequences`` is empty or ``expressions`` is not positive.
    RigError
        When a shape name is not in ``rig``.
    """
    if not sequences:
        raise ValueError("contact_sheet: sequences is empty; give at least one solver's expressions")
    if expressions < 1:
        raise ValueError(f"contact_sheet: expressions must be >= 1, got {expressions}")
    rows = {label: seq[:expressions] for label, seq in distinct_sequences(sequences).items()}
    columns = max(1, max(len(seq) for seq in rows.values()))
    most_names = max([len(e) for seq in rows.values() for e in seq] + [1])
    names_height = 0.16 * most_names
    active = binary_blendshapes(rig.deltas, mu)
    camera = camera_basis(rig)
    with report_style():
        figure = Figure(
            figsize=(2.1 * columns + 0.4, len(rows) * (2.3 + names_height) + 0.4), layout="constrained"
        )
        grid = figure.add_gridspec(2 * len(rows), columns, height_ratios=[2.0, names_height] * len(rows))
        for row, (label, seq) in enumerate(rows.items()):
            for column, shapes in enumerate(seq):
                face = figure.add_subplot(grid[2 * row, column])
                colours = draw_expression(face, rig, shapes, active, camera)
                face.set_title(
                    f"{label}\nexpression {column + 1}" if column == 0 else f"expression {column + 1}",
                    fontsize=8,
                    loc="left",
                )
                _list_names(figure.add_subplot(grid[2 * row + 1, column]), shapes, colours, most_names)
        if title:
            figure.suptitle(title, fontsize=11)
    return figure
