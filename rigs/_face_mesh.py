"""A face-like, exactly mirror-symmetric surface for procedural rigs (units: centimetres).

The surface is a graded grid over the front of a head, ``x`` left/right (the character's left is ``+x``,
symmetry plane ``x = 0``), ``y`` up and ``z`` toward the viewer. Rows are denser around the eyes and the
mouth; the grid is cut open along the lip line and the two eye lines (almond-shaped openings) and lifted
into a height field with eye sockets and eyeballs, brow ridge, cheekbones, nose with alae, lips, philtrum,
mentolabial sulcus and chin. Column ``j`` of a row is the mirror image of column ``n_columns - 1 - j``
(bit for bit), and cells left of the plane are split along the mirror image of the right cells' diagonal,
so vertices, triangles and anything built from them can be mirrored exactly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from registry import HarnessError

_DENSITY_SAMPLES = 4001
#: Relative steepness of the column grading (x = W * (u + c u^3) / (1 + c): denser near the midline).
_COLUMN_GRADING = 0.6
#: Fraction of the slit's row gap over which the above/below gates switch inside the slit.
_GATE_SHARPNESS = 0.45
#: The sketch region pairs of motion symmetry (sec. 4.4.2), upper region first.
MOTION_REGION_PAIRS = (
    ("upper_lip", "lower_lip"),
    ("upper_eyelid_L", "lower_eyelid_L"),
    ("upper_eyelid_R", "lower_eyelid_R"),
)
#: Each landmark is the centroid of these regions (`region_centre`), so a rig saved without its landmarks
#: still locates its features from its regions, to the same point.
LANDMARK_REGIONS = {
    "eye_L": ("upper_eyelid_L", "lower_eyelid_L"),
    "eye_R": ("upper_eyelid_R", "lower_eyelid_R"),
    "mouth": ("upper_lip", "lower_lip"),
    "nose": ("nose",),
}
#: Nose vertices are raised at least this fraction of the nose's projection by the nose.
_NOSE_SHARE = 0.3


@dataclass(frozen=True)
class FaceLayout:
    """Feature positions and sizes of the generated face, in centimetres.

    ``eye_y`` and ``mouth_y`` are snapped to the middle of the grid rows that the eye and lip lines
    cut between (see `build_face_mesh`); everything else is used as given.
    """

    top: float = 9.5
    bottom: float = -10.5
    half_width: float = 7.3
    eye_x: float = 3.2
    eye_y: float = 3.0
    eye_half_width: float = 1.4
    eye_opening: float = 0.45
    nose_tip_y: float = -1.6
    nose_projection: float = 2.4
    mouth_y: float = -4.6
    mouth_half_width: float = 2.4
    mouth_opening: float = 0.15


@dataclass(frozen=True)
class FaceMesh:
    """The generated surface and what the shape generator needs to know about it.

    Attributes
    ----------
    neutral : (N, 3) float array
    triangles : (T, 3) int array, counter-clockwise seen from ``+z``
    mirror : (N,) int array
        Index of each vertex's mirror image (``x -> -x``); an involution.
    row_y : (N,) float array
        Height of the vertex's grid row before the eye and mouth openings were pulled apart.
    normals : (N, 3) float array
        Unit normals of the height field (pointing toward ``+z``).
    layout : FaceLayout
        The layout with ``eye_y`` and ``mouth_y`` snapped between grid rows.
    gates : dict str -> (N,) float array
        ``above_mouth``, ``below_mouth``, ``above_eye``, ``below_eye``: 1 on one side of the lip or eye
        line, 0 on the other, switching sharply across the opening and smoothly beyond its corners.
    regions : dict str -> int array
        Sketch regions for motion symmetry: ``upper_lip``, ``lower_lip``, ``upper_eyelid_L/R``,
        ``lower_eyelid_L/R``; and the ``nose``.
    landmarks : dict str -> (3,) float array
        ``eye_L``, ``eye_R``, ``mouth``, ``nose``: centroids of their regions (`LANDMARK_REGIONS`).
    """

    neutral: np.ndarray
    triangles: np.ndarray
    mirror: np.ndarray
    row_y: np.ndarray
    normals: np.ndarray
    layout: FaceLayout
    gates: dict[str, np.ndarray]
    regions: dict[str, np.ndarray]
    landmarks: dict[str, np.ndarray]

    @property
    def n_vertices(self) -> int:
        return int(self.neutral.shape[0])

    def mirrored(self, field: np.ndarray) -> np.ndarray:
        """The mirror image of a per-vertex vector field: ``R field[mirror]`` with ``R = diag(-1, 1, 1)``."""
        image = field[self.mirror]
        image[:, 0] = -image[:, 0]
        return image


def grid_size(n_vertices: int, layout: FaceLayout) -> tuple[int, int]:
    """Odd column count and row count whose product is closest to ``n_vertices`` for the face's aspect."""
    aspect = (layout.top - layout.bottom) / (2.0 * layout.half_width)
    guess = int(round(np.sqrt(n_vertices / aspect)))
    best = None
    for n_columns in range(max(5, guess - 6) | 1, guess + 8, 2):
        n_rows = max(5, int(round(n_vertices / n_columns)))
        error = abs(n_columns * n_rows - n_vertices)
        if best is None or error < best[0]:
            best = (error, n_columns, n_rows)
    assert best is not None
    return best[1], best[2]


def build_face_mesh(n_vertices: int, layout: FaceLayout = FaceLayout()) -> FaceMesh:
    """Build the face surface with about ``n_vertices`` vertices.

    Parameters
    ----------
    n_vertices : int
        Target vertex count; the grid is chosen so the actual count is as close as its shape allows
        (within 1.5%, and 0.7% from 1000 vertices on).
    layout : FaceLayout
        Feature positions and sizes.

    Returns
    -------
    FaceMesh

    Raises
    ------
    ValueError
        When the grid is too coarse to separate the eye line from the lip line.
    """
    n_columns, n_rows = grid_size(n_vertices, layout)
    row_heights = _graded_rows(n_rows, layout)
    eye_row, eye_y = _snap_between_rows(row_heights, layout.eye_y)
    mouth_row, mouth_y = _snap_between_rows(row_heights, layout.mouth_y)
    if eye_row == mouth_row:
        raise HarnessError(
            f"n_vertices={n_vertices} is too coarse: the eye and lip lines fall between the same rows"
        )
    layout = replace(layout, eye_y=eye_y, mouth_y=mouth_y)

    half = _COLUMN_GRADING
    u = np.linspace(0.0, 1.0, n_columns // 2 + 1)
    right = (u + half * u**3) / (1.0 + half)
    column_x = np.concatenate([-right[:0:-1], right])  # column j mirrors column n_columns - 1 - j exactly

    row_y = np.repeat(row_heights, n_columns)
    x = np.repeat(_half_width(row_heights, layout), n_columns) * np.tile(column_x, n_rows)
    row_index = np.repeat(np.arange(n_rows), n_columns)
    column = np.tile(np.arange(n_columns), n_rows)
    mirror = row_index * n_columns + (n_columns - 1 - column)
    eye_gap = row_heights[eye_row + 1] - row_heights[eye_row]
    mouth_gap = row_heights[mouth_row + 1] - row_heights[mouth_row]
    y = _even(row_y + _opening_offsets(x, row_y, row_index, eye_row, mouth_row, layout), x, mirror)
    z = _even(face_height(x, y, layout), x, mirror)
    neutral = np.column_stack([x, y, z])
    triangles = _triangulate(
        n_rows, n_columns, _open_cells(x, row_index, eye_row, mouth_row, n_columns, layout)
    )

    gates = _gates(x, row_y, layout, eye_gap, mouth_gap)
    nose = _even(_nose_height(x, y, layout), x, mirror) >= _NOSE_SHARE * layout.nose_projection
    regions = _regions(x, row_y, nose, layout, eye_gap, mouth_gap)
    return FaceMesh(
        neutral=neutral,
        triangles=triangles,
        mirror=mirror,
        row_y=row_y,
        normals=_height_field_normals(x, y, layout),
        layout=layout,
        gates=gates,
        regions=regions,
        landmarks={name: region_centre(neutral, regions, names) for name, names in LANDMARK_REGIONS.items()},
    )


def region_centre(neutral: np.ndarray, regions: dict[str, np.ndarray], names: tuple[str, ...]) -> np.ndarray:
    """Centroid of the vertices of the named regions, summed exactly (``math.fsum``), so mirror-image
    regions have mirror-image centres bit for bit."""
    points = neutral[np.concatenate([regions[name] for name in names])]
    return np.array([math.fsum(column) for column in points.T]) / len(points)


def _even(values: np.ndarray, x: np.ndarray, mirror: np.ndarray) -> np.ndarray:
    """Copy the right half's values onto the left half, so a function even in ``x`` is exactly even
    (vectorised transcendental functions may round the same argument differently at different positions)."""
    return np.where(x < 0, values[mirror], values)


def face_height(x: np.ndarray, y: np.ndarray, layout: FaceLayout) -> np.ndarray:
    """Depth ``z`` of the face surface over ``(x, y)``; even in ``x``, so the surface is mirror-symmetric."""
    ax = np.abs(x)
    eye_x, eye_y, eye_w = layout.eye_x, layout.eye_y, layout.eye_half_width
    mouth_y, mouth_w = layout.mouth_y, layout.mouth_half_width

    def bump(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return np.exp(-(a * a + b * b))

    z = -(x * x) / 16.0 - 0.0015 * x**4 - (y - 1.0) ** 2 / 40.0
    z -= 1.1 * bump((ax - eye_x) / (1.45 * eye_w), (y - eye_y) / 1.5)  # eye socket
    z += 0.75 * bump((ax - eye_x) / (0.9 * eye_w), (y - eye_y) / (0.75 + layout.eye_opening))  # eyeball
    z += 0.45 * np.exp(-(((y - eye_y - 1.9) / 0.8) ** 2) - ((ax - 0.85 * eye_x) / 2.6) ** 2)  # brow ridge
    z += 0.8 * bump((ax - eye_x - 1.1) / 1.8, (y - eye_y + 2.3) / 1.7)  # cheekbone

    z += _nose_height(x, y, layout)
    z += 0.7 * bump(x / (mouth_w + 0.8), (y - mouth_y) / 2.4)  # muzzle over the teeth
    z += 0.45 * bump(x / (0.85 * mouth_w), (y - mouth_y - 0.35) / 0.4)  # upper lip
    z += 0.5 * bump(x / (0.8 * mouth_w), (y - mouth_y + 0.45) / 0.5)  # lower lip
    z -= 0.12 * bump(x / 0.35, (y - mouth_y - 1.0) / 0.5)  # philtrum
    z -= 0.25 * bump(x / 2.0, (y - mouth_y + 1.7) / 0.5)  # mentolabial sulcus
    z += 0.6 * bump(x / 2.2, (y - mouth_y + 4.0) / 1.4)  # chin
    return z


def _nose_height(x: np.ndarray, y: np.ndarray, layout: FaceLayout) -> np.ndarray:
    """The nose's part of `face_height`: a ridge rising to the tip, then the alae."""
    tip_y = layout.nose_tip_y
    ridge = np.clip((layout.eye_y + 1.0 - y) / (layout.eye_y + 1.0 - tip_y), 0.0, 1.0)
    ridge = ridge * ridge * (3.0 - 2.0 * ridge)
    profile = np.where(y >= tip_y, ridge, np.exp(-(((y - tip_y) / 0.8) ** 2)))
    width = 0.6 + 0.7 * np.where(y >= tip_y, ridge, 1.0)
    alae = np.exp(-(((np.abs(x) - 1.25) / 0.55) ** 2) - ((y - tip_y + 0.45) / 0.55) ** 2)
    return layout.nose_projection * (profile * np.exp(-((x / width) ** 2)) + 0.3 * alae)


def _graded_rows(n_rows: int, layout: FaceLayout) -> np.ndarray:
    """Row heights from bottom to top, denser around the eye and lip lines (inverse cumulative density)."""
    samples = np.linspace(layout.bottom, layout.top, _DENSITY_SAMPLES)
    density = (
        1.0
        + 1.0 * np.exp(-(((samples - layout.eye_y) / 1.5) ** 2))
        + 1.4 * np.exp(-(((samples - layout.mouth_y) / 1.5) ** 2))
    )
    cumulative = np.concatenate([[0.0], np.cumsum(0.5 * (density[1:] + density[:-1]) * np.diff(samples))])
    return np.interp(np.linspace(0.0, cumulative[-1], n_rows), cumulative, samples)


def _snap_between_rows(row_heights: np.ndarray, height: float) -> tuple[int, float]:
    """The row just below ``height`` and the midpoint between it and the next row."""
    row = int(np.clip(np.searchsorted(row_heights, height) - 1, 0, len(row_heights) - 2))
    return row, 0.5 * float(row_heights[row] + row_heights[row + 1])


def _half_width(y: np.ndarray, layout: FaceLayout) -> np.ndarray:
    """Half width of the face at height ``y`` (narrowing toward the chin)."""
    chin = np.clip((layout.mouth_y - 0.4 - y) / 5.5, 0.0, 1.0)
    return layout.half_width - 0.016 * (y - 1.0) ** 2 - 1.5 * chin * chin * (3.0 - 2.0 * chin)


def _almond(t: np.ndarray) -> np.ndarray:
    """``(1 - t^2)^2`` inside ``|t| < 1``, 0 outside: the opening profile along an eye or the mouth."""
    inside = np.clip(1.0 - t * t, 0.0, None)
    return inside * inside


def _opening_offsets(
    x: np.ndarray, row_y: np.ndarray, row_index: np.ndarray, eye_row: int, mouth_row: int, layout: FaceLayout
) -> np.ndarray:
    """Vertical offsets that pull the rows on either side of each slit apart into an opening.

    A row at distance ``s`` (in units of the spread ``w = 3 A``) from the line moves by ``A (1 - s)^2``
    away from it, so rows keep their order (the offset's slope is at most ``2 A / w = 2/3``).
    """
    offsets = np.zeros_like(row_y)
    lines = (
        (
            eye_row,
            layout.eye_y,
            layout.eye_opening * _almond((np.abs(x) - layout.eye_x) / layout.eye_half_width),
        ),
        (mouth_row, layout.mouth_y, layout.mouth_opening * _almond(x / layout.mouth_half_width)),
    )
    for row, line_y, amplitude in lines:
        peak = float(amplitude.max())
        if peak <= 0.0:
            continue
        spread = 3.0 * peak
        falloff = np.clip(1.0 - np.abs(row_y - line_y) / spread, 0.0, None) ** 2
        offsets += np.where(row_index > row, 1.0, -1.0) * amplitude * falloff
    return offsets


def _open_cells(
    x: np.ndarray, row_index: np.ndarray, eye_row: int, mouth_row: int, n_columns: int, layout: FaceLayout
) -> np.ndarray:
    """(n_rows - 1, n_columns - 1) bool: grid cells removed to open the mouth and the eyes."""
    n_rows = row_index[-1] + 1
    opened = np.zeros((n_rows - 1, n_columns - 1), dtype=bool)
    for row, inside in (
        (mouth_row, np.abs(x) < layout.mouth_half_width),
        (eye_row, np.abs(np.abs(x) - layout.eye_x) < layout.eye_half_width),
    ):
        along = inside.reshape(n_rows, n_columns)[row]
        opened[row] = along[:-1] & along[1:]
    return opened


def _triangulate(n_rows: int, n_columns: int, opened: np.ndarray) -> np.ndarray:
    """Two triangles per kept cell; the left half uses the mirror image of the right half's diagonal."""
    rows, columns = np.nonzero(~opened)
    a = rows * n_columns + columns  # bottom left
    b = a + 1  # bottom right
    c = a + n_columns + 1  # top right
    d = a + n_columns  # top left
    left = (columns + 1) <= n_columns // 2
    first = np.where(left[:, None], np.column_stack([a, b, c]), np.column_stack([a, b, d]))
    second = np.where(left[:, None], np.column_stack([a, c, d]), np.column_stack([b, c, d]))
    return np.concatenate([first, second]).astype(np.int64)


def _height_field_normals(x: np.ndarray, y: np.ndarray, layout: FaceLayout, step: float = 1e-4) -> np.ndarray:
    """Unit normals ``(-dz/dx, -dz/dy, 1) / norm`` by central differences of `face_height`."""
    dz_dx = (face_height(x + step, y, layout) - face_height(x - step, y, layout)) / (2.0 * step)
    dz_dy = (face_height(x, y + step, layout) - face_height(x, y - step, layout)) / (2.0 * step)
    normals = np.column_stack([-dz_dx, -dz_dy, np.ones_like(x)])
    return normals / np.linalg.norm(normals, axis=1, keepdims=True)


def _smoothstep(t: np.ndarray) -> np.ndarray:
    t = np.clip(t, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _line_gate(
    row_y: np.ndarray, line_y: float, outside: np.ndarray, gap: float, widening: float, reach: float
) -> np.ndarray:
    """1 above a cut line and 0 below it: a step across the opening, widening to ``widening`` over
    ``reach`` beyond the corners (``outside`` is the distance past the nearest corner, 0 along the cut)."""
    width = _GATE_SHARPNESS * gap + (widening - _GATE_SHARPNESS * gap) * _smoothstep(outside / reach)
    return _smoothstep((row_y - line_y + width) / (2.0 * width))


def _gates(x: np.ndarray, row_y: np.ndarray, layout: FaceLayout, eye_gap: float, mouth_gap: float) -> dict:
    ax = np.abs(x)
    mouth = _line_gate(
        row_y, layout.mouth_y, np.clip(ax - layout.mouth_half_width, 0.0, None), mouth_gap, 1.5, 1.5
    )
    eye = _line_gate(
        row_y,
        layout.eye_y,
        np.clip(np.abs(ax - layout.eye_x) - layout.eye_half_width, 0.0, None),
        eye_gap,
        0.8,
        0.6,
    )
    return {"above_mouth": mouth, "below_mouth": 1.0 - mouth, "above_eye": eye, "below_eye": 1.0 - eye}


def _regions(
    x: np.ndarray, row_y: np.ndarray, nose: np.ndarray, layout: FaceLayout, eye_gap: float, mouth_gap: float
) -> dict:
    """Sketch regions (sec. 4.4.2): the lips up to 1 cm from the lip line and short of the corners, and
    each eyelid from its lid edge up to ``0.55 + opening`` cm (upper) or ``0.65 + opening`` cm (lower);
    and the ``nose`` (the vertices in the mask ``nose``)."""
    lip_span = np.abs(x) <= layout.mouth_half_width - 0.3
    above_mouth = row_y - layout.mouth_y
    upper_reach = max(0.55 + layout.eye_opening, eye_gap)
    lower_reach = max(0.65 + layout.eye_opening, eye_gap)
    lid_span = np.abs(np.abs(x) - layout.eye_x) <= layout.eye_half_width
    above_eye = row_y - layout.eye_y
    lip_reach = max(1.0, mouth_gap)
    regions = {
        "upper_lip": lip_span & (above_mouth > 0) & (above_mouth <= lip_reach),
        "lower_lip": lip_span & (above_mouth < 0) & (-above_mouth <= lip_reach),
        "nose": nose,
    }
    for side, on_side in (("L", x > 0), ("R", x < 0)):
        regions[f"upper_eyelid_{side}"] = on_side & lid_span & (above_eye > 0) & (above_eye <= upper_reach)
        regions[f"lower_eyelid_{side}"] = on_side & lid_span & (above_eye < 0) & (-above_eye <= lower_reach)
    return {name: np.flatnonzero(mask) for name, mask in regions.items()}
