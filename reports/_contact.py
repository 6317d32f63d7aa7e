"""Expression contact sheets: each reference expression drawn as a shaded face, its shapes coloured.

An artist takes these to a scanning session (Carrigan et al. 2020, sec. 5.3 and Fig. 11): every panel shows
the template posed in one expression (neutral plus the sum of its blendshapes, sec. 3), the active vertices
of each blendshape (eq. 2, the masks packing used: `render.active_vertices`) in that shape's colour, and
the shape names underneath. The face is seen through `rigs.frontal_camera` and drawn by
`render.render_mesh`, the camera and renderer of the pictures of ``harness pack``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

import render
from reports._png import report_style
from rigs import Rig, frontal_camera

#: Width in pixels of a rendered face (drawn supersampled into its panel).
PANEL_WIDTH = 320


def draw_expression(
    ax: Axes,
    rig: Rig,
    shapes: Sequence[str],
    active: np.ndarray,
    camera: np.ndarray,
    *,
    size: tuple[int, int] = (PANEL_WIDTH, PANEL_WIDTH),
) -> np.ndarray:
    """Draw ``rig`` posed in the expression made of ``shapes`` onto ``ax`` (`render.render_mesh`).

    Parameters
    ----------
    ax : matplotlib Axes
        Target axes (their ticks and frame are switched off).
    rig : Rig
        The template rig.
    shapes : sequence of str
        Blendshape names of the expression; each gets its own colour (`render.shape_colours`), and a
        triangle takes the colour of the shape most of its corners are active in.
    active : (K, N) bool array
        Active vertices of every blendshape of ``rig`` (eq. 2), as from `render.active_vertices`.
    camera : (3, 3) array
        Rows right, up and towards the viewer, as from `rigs.frontal_camera`.
    size : (width, height)
        Size in pixels of the rendered image; the face is fitted and centred in it.

    Returns
    -------
    (len(shapes), 3) array of the RGB colours used for the shapes, in order.
    """
    indices = rig.indices(shapes)
    colours = render.shape_colours([1] * len(indices))
    fills = render.triangle_colours(rig.triangles, active[indices], colours)
    posed = rig.neutral + rig.deltas[indices].sum(axis=0)
    image = render.render_mesh(posed, rig.triangles, camera, fills, width=size[0], height=size[1])
    ax.imshow(image, interpolation="antialiased")
    ax.set_axis_off()
    return colours


def _panel_size(rig: Rig, camera: np.ndarray, width: int = PANEL_WIDTH) -> tuple[int, int]:
    """``(width, height)`` of a panel that fits the rig's neutral seen through ``camera`` (its height
    at most twice and at least half its width)."""
    extent = np.ptp(rig.neutral @ np.asarray(camera).T, axis=0)
    aspect = float(np.clip(extent[1] / max(extent[0], 1e-300), 0.5, 2.0))
    return width, int(round(width * aspect))


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
        Activity threshold of eq. 2 used to colour each shape's active vertices (the run's ``mu``; the
        noise floor is packing's, `render.active_vertices`).
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
    active = render.active_vertices(rig, mu)
    camera = frontal_camera(rig)
    size = _panel_size(rig, camera)
    with report_style():
        figure = Figure(
            figsize=(2.1 * columns + 0.4, len(rows) * (2.3 + names_height) + 0.4), layout="constrained"
        )
        grid = figure.add_gridspec(2 * len(rows), columns, height_ratios=[2.0, names_height] * len(rows))
        for row, (label, seq) in enumerate(rows.items()):
            for column, shapes in enumerate(seq):
                face = figure.add_subplot(grid[2 * row, column])
                colours = draw_expression(face, rig, shapes, active, camera, size=size)
                face.set_title(
                    f"{label}\nexpression {column + 1}" if column == 0 else f"expression {column + 1}",
                    fontsize=8,
                    loc="left",
                )
                _list_names(figure.add_subplot(grid[2 * row + 1, column]), shapes, colours, most_names)
        if title:
            figure.suptitle(title, fontsize=11)
    return figure
