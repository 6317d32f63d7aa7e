"""The renderer of expressions: a z-buffered, smoothly shaded render with the active shapes coloured.

An expression is the template posed in it (neutral plus the sum of its blendshapes, Carrigan et al. 2020,
sec. 3) and seen through a camera such as `rigs.frontal_camera`. A triangle takes the colour of the
expression's shape most of its corners are active in (eq. 2, with the masks packing used:
`active_vertices`); no colour repeats within an expression (`shape_colours`).

`rasterise` is the one rasteriser: scanline conversion in numpy with a depth buffer (nearest surface
wins, exactly, also where triangles cross), Gouraud-shaded by a two-sided Lambert light and supersampled
for smooth edges, into a `Raster` that `Raster.paint` colours. `render_mesh` fits a mesh into an image
(the report's contact sheets, `reports.contact_sheet`); the session pictures
(`session._pictures`) frame every expression alike and raster again only what an expression
moves (`Backdrop`).
"""

from __future__ import annotations

import colorsys
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
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
SKIN = np.array([0.86, 0.84, 0.82])
#: Light direction in camera coordinates (from the upper left, towards the face).
_LIGHT = np.array([-0.35, 0.45, 1.0]) / np.linalg.norm([-0.35, 0.45, 1.0])
_AMBIENT, _DIFFUSE = 0.3, 0.7
#: Samples per pixel along each axis (the image is rendered this much larger and averaged down).
SUPERSAMPLE = 2
#: Largest number of pixel samples rasterised at once (about 100 MB of temporaries): bounds the memory
#: of meshes with many large, overlapping triangles.
_CHUNK_SAMPLES = 2_000_000


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
    active, triangles = np.asarray(active, dtype=bool), np.asarray(triangles).reshape(-1, 3)
    palette = np.vstack([np.asarray(colours, dtype=np.float64).reshape(len(active), 3), SKIN])
    touched = np.flatnonzero(active.any(axis=0)[triangles].any(axis=1))  # a corner active in some shape
    corners = active[:, triangles[touched]].sum(axis=2)  # (S, touched)
    labels = np.full(len(triangles), -1)  # -1 picks the skin row
    labels[touched] = corners.argmax(axis=0)
    return palette[labels]


@dataclass(frozen=True)
class Frame:
    """Where an orthographic camera's view lands in a picture of ``width`` x ``height`` pixels of
    ``supersample`` x ``supersample`` samples: a camera coordinate ``(u, v)`` is at sample
    ``((u - centre[0]) * scale + columns / 2, (centre[1] - v) * scale + rows / 2)``.

    One frame for several poses (`fitted` to all of them) keeps them the same size and place, so the
    pictures compare and the unmoved part of the face is rasterised once (`Backdrop`).
    """

    camera: np.ndarray
    centre: np.ndarray
    scale: float
    width: int
    height: int
    supersample: int = SUPERSAMPLE

    @classmethod
    def fitted(
        cls,
        camera: np.ndarray,
        poses: Sequence[np.ndarray],
        *,
        width: int,
        height: int,
        margin: float = 0.03,
        supersample: int = SUPERSAMPLE,
    ) -> Frame:
        """The frame in which every pose's projection fits the picture, less ``margin`` (a share of its
        larger side) on every side, centred."""
        camera = np.asarray(camera, dtype=np.float64)
        extents = np.array([_extent(np.asarray(pose, dtype=np.float64) @ camera[:2].T) for pose in poses])
        low, high = extents[:, 0].min(axis=0), extents[:, 1].max(axis=0)
        size = np.array([width, height], dtype=np.float64) * supersample
        room = np.maximum(size - 2.0 * margin * size.max(), 1.0)
        scale = float(np.min(room / np.maximum(high - low, 1e-300)))
        return cls(camera, (low + high) / 2.0, scale, width, height, supersample)

    @property
    def samples(self) -> tuple[int, int]:
        """Samples across and down."""
        return self.width * self.supersample, self.height * self.supersample

    def project(self, vertices: np.ndarray) -> np.ndarray:
        """(N, 3) sample coordinates of ``vertices``: x right, y down, z nearness."""
        u, v, z = (_dot(vertices, axis) for axis in self.camera)
        columns, rows = self.samples
        x = (u - self.centre[0]) * self.scale + columns / 2.0
        y = (self.centre[1] - v) * self.scale + rows / 2.0
        return np.stack([x, y, z], axis=1)

    def brightness(self, normals: np.ndarray) -> np.ndarray:
        """Two-sided Lambert brightness of vertices of unit ``normals`` (`vertex_normals`)."""
        return _AMBIENT + _DIFFUSE * np.abs(_dot(normals, self.camera.T @ _LIGHT))


@dataclass(frozen=True)
class Raster:
    """A mesh seen in a `Frame`, before colour: at every sample the nearest triangle (``nearest``, -1
    where none), the light on it there (``light``) and, for a mesh that fades out, its opacity there
    (``opacity``, in [0, 1]; None for an opaque mesh).

    One raster gives any number of pictures of the same pose and view (`paint`): the shapes coloured, or
    the bare skin.
    """

    nearest: np.ndarray
    light: np.ndarray
    supersample: int
    opacity: np.ndarray | None = None

    def paint(self, colours: np.ndarray) -> np.ndarray:
        """The (height, width, 4) uint8 RGBA image of the raster with ``colours``: (T, 3) RGB in [0, 1]
        per triangle, or one (3,) RGB for every triangle; straight RGB, alpha the share of the pixel
        the mesh covers."""
        rgb, coverage = self._sums(colours)
        covered = coverage[..., None]
        straight = np.divide(rgb, covered, out=np.zeros_like(rgb), where=covered > 0)
        image = np.concatenate([np.clip(straight, 0.0, 1.0), covered / self.supersample**2], axis=2)
        return (image * 255.0 + 0.5).astype(np.uint8)

    def over(self, colours: np.ndarray | float, background: np.ndarray | float) -> np.ndarray:
        """The uint8 image of `paint` composited over ``background``: (height, width, 3) RGB for RGB
        colours, or (height, width) grey for one grey level ``colours`` over a grey ``background``."""
        rgb, coverage = self._sums(colours)
        share = np.float32(1.0 / self.supersample**2)
        uncovered = np.multiply.outer(1.0 - coverage * share, np.asarray(background, dtype=np.float32))
        return (np.clip(rgb * share + uncovered, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)

    def _sums(self, colours: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """Per pixel, the sum of its samples' shaded colour and the number of them covered (float32)."""
        colours = np.asarray(colours, dtype=np.float32)
        covered = (self.nearest >= 0).astype(np.float32)
        light = self.light
        if self.opacity is not None:  # (0 where no triangle is)
            covered, light = self.opacity.astype(np.float32), light * self.opacity
        coverage = _blocks(covered, self.supersample)
        if colours.ndim <= 1:  # one colour (or grey level) for every triangle
            return np.multiply.outer(_blocks(light, self.supersample), colours), coverage
        table = np.vstack([colours.reshape(-1, 3), np.zeros((1, 3), dtype=np.float32)])  # -1: none
        channels = [np.take(table[:, c], self.nearest) * light for c in range(3)]
        return np.stack([_blocks(channel, self.supersample) for channel in channels], axis=2), coverage


def _blocks(samples: np.ndarray, factor: int) -> np.ndarray:
    """Sums of the ``factor`` x ``factor`` blocks of a (rows, columns) array of samples: one per pixel."""
    return sum(samples[row::factor, column::factor] for row in range(factor) for column in range(factor))


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
    `rasterise` in a `Frame` fitted to the mesh, then `Raster.paint`: the nearest surface wins at every
    sample (a depth buffer), so the picture is right where triangles cross or a mesh folds over itself,
    unlike the painter's algorithm. Lighting is two-sided, since the orientation of a rig's mesh is
    unknown. O(T + P) for P covered samples (pixels times supersample squared times overdraw), in numpy;
    the same input gives the same image.
    """
    frame = Frame.fitted(
        camera, [vertices], width=width, height=height, margin=margin, supersample=supersample
    )
    return rasterise(vertices, triangles, frame).paint(colours)


def coincident(vertices: np.ndarray) -> np.ndarray:
    """(N,) for each vertex the first vertex at exactly its position: itself when it has no twin.

    Exporters split a vertex along UV and material seams (glTF always does): the copies are twins at one
    position, and a surface that is smooth across the seam needs one normal for all of them
    (`vertex_normals`). O(N log N).
    """
    vertices = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    order = np.lexsort(vertices.T[::-1])
    ranked = vertices[order]
    starts = np.ones(len(order), dtype=bool)
    starts[1:] = (ranked[1:] != ranked[:-1]).any(axis=1)
    first = np.minimum.reduceat(order, np.flatnonzero(starts)) if len(order) else order
    twins = np.empty(len(order), dtype=np.intp)
    twins[order] = first[np.cumsum(starts) - 1]
    return twins


def vertex_normals(
    vertices: np.ndarray, triangles: np.ndarray, twins: np.ndarray | None = None
) -> np.ndarray:
    """(N, 3) unit area-weighted normal of each vertex (0 for a vertex in no triangle of any area), one
    normal for the twins of a seam (``twins``: `coincident` of ``vertices``, found here when not given),
    so that shading does not break along it.

    Each vertex sums its triangles' normals (and its twins') in the order of ``triangles``, so the
    normals of the vertices all of whose (and whose twins') triangles are in a subset come out bit for
    bit the same from that subset.
    """
    triangles = np.asarray(triangles, dtype=np.intp).reshape(-1, 3)
    if twins is None:
        twins = coincident(vertices)
    corners = np.asarray(vertices, dtype=np.float64)[triangles.T]  # (3 corners, T, 3)
    normals = np.cross(corners[1] - corners[0], corners[2] - corners[0])
    owners = twins[triangles].ravel(order="F")
    summed = np.stack(
        [np.bincount(owners, np.tile(normals[:, axis], 3), minlength=len(twins)) for axis in range(3)],
        axis=1,
    ).astype(np.float64)[twins]  # (float even without triangles)
    lengths = np.linalg.norm(summed, axis=1, keepdims=True)
    return np.divide(summed, lengths, out=np.zeros_like(summed), where=lengths > 0)


def rasterise(
    vertices: np.ndarray,
    triangles: np.ndarray,
    frame: Frame,
    normals: np.ndarray | None = None,
    opacity: np.ndarray | None = None,
) -> Raster:
    """The `Raster` of a mesh in ``frame``; ``normals`` (`vertex_normals` of ``vertices``) spare their
    computation when one pose is seen in several frames; ``opacity`` (N,) in [0, 1] per vertex
    (`render.edge_fade`) fades the mesh into the background where it is below 1."""
    triangles = np.asarray(triangles, dtype=np.intp).reshape(-1, 3)
    if normals is None:
        normals = vertex_normals(vertices, triangles)
    corners = frame.project(vertices).T[:, triangles.T]  # (3 coordinates, 3 corners, T)
    values = [frame.brightness(normals)[triangles.T]]
    if opacity is not None:
        values.append(np.asarray(opacity, dtype=np.float64)[triangles.T])
    depth_plane, shade_plane, *opacity_plane = _planes(corners, *values)
    nearest, depth = _buffers(frame)
    for pixel, owner, near in _scan(corners, depth_plane, frame.samples):
        _keep_nearest(nearest, depth, pixel, owner, near)
    return _raster(nearest, shade_plane, frame, *opacity_plane)


def _dot(vectors: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """(N,) dot products of (N, 3) ``vectors`` with ``direction``, written out so that a row's result
    does not depend on the others (as a BLAS product's may)."""
    vectors = np.asarray(vectors, dtype=np.float64)
    return vectors[:, 0] * direction[0] + vectors[:, 1] * direction[1] + vectors[:, 2] * direction[2]


def _extent(view: np.ndarray) -> np.ndarray:
    """(2, 2): the lowest and the highest camera (x, y) of a projected mesh (zeros for none)."""
    return np.array([view.min(axis=0), view.max(axis=0)]) if len(view) else np.zeros((2, 2))


def _buffers(frame: Frame) -> tuple[np.ndarray, np.ndarray]:
    """Empty nearest-triangle (-1) and depth (-inf) buffers of the frame's samples, row by row."""
    count = frame.samples[0] * frame.samples[1]
    return np.full(count, -1, dtype=np.int32), np.full(count, -np.inf)


def _raster(
    nearest: np.ndarray, shade_plane: np.ndarray, frame: Frame, opacity_plane: np.ndarray | None = None
) -> Raster:
    columns, rows = frame.samples
    image = nearest.reshape(rows, columns)
    opacity = None if opacity_plane is None else np.clip(_light(image, opacity_plane), 0.0, 1.0)
    return Raster(image, _light(image, shade_plane), frame.supersample, opacity)


class Backdrop:
    """The neutral seen in a `Frame`, kept so that a pose's `Raster` needs only the triangles the pose
    changes rasterised again: the same raster, sample for sample, as `rasterise` of the whole pose.

    Only the triangles with a moved corner are rasterised again (`Motion.moved`); where the neutral's
    nearest triangle at a sample is one of them, the nearest unmoved triangle there is found among the
    neutral's kept samples. A triangle with a corner whose normal some moved vertex bends keeps its
    samples and gets the light of the bent normals (`Motion.changed`); the others keep their light too.

    Parameters
    ----------
    neutral : (N, 3) array
    triangles : (T, 3) int array
    frame : Frame
    normals : (N, 3) array
        `vertex_normals` of the neutral.
    opacity : (N,) array, optional
        Opacity of each vertex (`render.edge_fade`), the same in every pose.
    """

    def __init__(
        self,
        neutral: np.ndarray,
        triangles: np.ndarray,
        frame: Frame,
        normals: np.ndarray,
        opacity: np.ndarray | None = None,
    ) -> None:
        self.triangles = np.asarray(triangles, dtype=np.intp).reshape(-1, 3)
        self.frame = frame
        self.opacity = None if opacity is None else np.asarray(opacity, dtype=np.float64)
        corners = frame.project(neutral).T[:, self.triangles.T]
        self.depth_plane, self.shade_plane, *opacity_plane = _planes(
            corners, frame.brightness(normals)[self.triangles.T], *self._opacity(self.triangles)
        )
        self.opacity_plane = opacity_plane[0] if opacity_plane else None
        self.nearest, self.depth = _buffers(frame)
        pieces = list(_scan(corners, self.depth_plane, frame.samples))
        for pixel, owner, near in pieces:
            _keep_nearest(self.nearest, self.depth, pixel, owner, near)
        self.pixel, self.owner, self.near = (
            np.concatenate([piece[k] for piece in pieces]) if pieces else np.zeros(0, dtype)
            for k, dtype in enumerate((np.int64, np.int32, np.float64))
        )

    def pose(self, vertices: np.ndarray, motion: Motion) -> Raster:
        """The raster of the pose ``vertices``, whose `Motion` from the neutral is ``motion``."""
        moved = np.append(motion.moved, False)  # index -1 (no triangle): not moved
        nearest, depth = self.nearest.copy(), self.depth.copy()
        hole = moved[nearest]
        nearest[hole], depth[hole] = -1, -np.inf
        refill = hole[self.pixel] & ~moved[self.owner]
        _keep_nearest(nearest, depth, self.pixel[refill], self.owner[refill], self.near[refill])
        lit = np.flatnonzero(motion.changed)  # every moved triangle is among them
        corners = self.frame.project(vertices).T[:, self.triangles[lit].T]
        brightness = self.frame.brightness(motion.normals)[self.triangles[lit].T]
        depth_plane, lit_shade, *lit_opacity = _planes(
            corners, brightness, *self._opacity(self.triangles[lit])
        )
        scanned = motion.moved[lit]
        moving = lit[scanned]
        for pixel, owner, near in _scan(corners[:, :, scanned], depth_plane[scanned], self.frame.samples):
            _keep_nearest(nearest, depth, pixel, moving[owner].astype(np.int32), near)
        shade_plane = self.shade_plane.copy()
        shade_plane[lit] = lit_shade
        opacity_plane = None
        if self.opacity_plane is not None:
            opacity_plane = self.opacity_plane.copy()
            opacity_plane[lit] = lit_opacity[0]
        return _raster(nearest, shade_plane, self.frame, opacity_plane)

    def _opacity(self, triangles: np.ndarray) -> list[np.ndarray]:
        """The opacity at the corners of ``triangles`` ((3, T)), as the one item of a list; none without
        an opacity."""
        return [] if self.opacity is None else [self.opacity[triangles.T]]


@dataclass(frozen=True)
class Motion:
    """What a pose changes of its neutral: ``moved`` (T,) the triangles with a moved corner, ``changed``
    (T,) the triangles with a corner whose normal is bent (the moved ones among them), ``normals`` (N, 3)
    the pose's `vertex_normals`."""

    moved: np.ndarray
    changed: np.ndarray
    normals: np.ndarray

    @classmethod
    def of(
        cls,
        vertices: np.ndarray,
        neutral: np.ndarray,
        triangles: np.ndarray,
        neutral_normals: np.ndarray,
        twins: np.ndarray | None = None,
    ) -> Motion:
        """The motion from ``neutral`` (of normals ``neutral_normals``, made with the twins ``twins``:
        `coincident` of the neutral, found here when not given) to the pose ``vertices``."""
        triangles = np.asarray(triangles, dtype=np.intp).reshape(-1, 3)
        if twins is None:
            twins = coincident(neutral)
        shifted = (np.asarray(vertices) != np.asarray(neutral)).any(axis=1)
        moved = shifted[triangles].any(axis=1)
        touched = np.zeros(len(shifted), dtype=bool)  # corners of a triangle that moved, and their twins:
        touched[twins[triangles[moved].ravel()]] = True  # their normals change
        bent = touched[twins]
        changed = bent[triangles].any(axis=1)  # every triangle of a bent vertex: its own normals are exact
        normals = np.array(neutral_normals, dtype=np.float64)
        normals[bent] = vertex_normals(vertices, triangles[changed], twins)[bent]
        return cls(moved, changed, normals)


def _planes(corners: np.ndarray, *values: np.ndarray) -> list[np.ndarray]:
    """Per triangle, depth and each of ``values`` (at its corners, (3, T): brightness, opacity) as planes
    ``a x + b y + c`` over the image, (T, 3) rows ``a, b, c`` (orthographic projection keeps them affine
    across a triangle); NaN rows for triangles of no area in the image."""
    x, y = corners[0], corners[1]
    following, last = (1, 2, 0), (2, 0, 1)
    a = y[following, :] - y[last, :]  # barycentric coordinate i = (a_i x + b_i y + c_i) / area
    b = x[last, :] - x[following, :]
    c = x[following, :] * y[last, :] - x[last, :] * y[following, :]
    area = c[0] + c[1] + c[2]
    flat = np.abs(area) <= 1e-9
    scale = np.where(flat, np.nan, 1.0 / np.where(flat, 1.0, area))

    def plane(at_corners: np.ndarray) -> np.ndarray:  # (T, 3): written out, the same sums for any subset
        sums = [k[0] * at_corners[0] + k[1] * at_corners[1] + k[2] * at_corners[2] for k in (a, b, c)]
        return np.stack(sums, axis=1) * scale[:, None]

    return [plane(corners[2]), *(plane(at_corners) for at_corners in values)]


def _scan(
    corners: np.ndarray, depth_plane: np.ndarray, size: tuple[int, int]
) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """(pixel index, triangle, depth) of every pixel centre inside the triangles ``corners`` (3
    coordinates, 3 corners, T), in chunks of at most `_CHUNK_SAMPLES` samples.

    Triangles are cut into rows of pixel centres and rows into spans (scanline conversion, all in
    numpy); a centre on a shared edge belongs to both triangles. `_keep_nearest` merges the chunks into
    depth buffers.
    """
    width, height = size
    edges = _edges(corners)
    planes = np.ascontiguousarray(depth_plane.T)  # (3, T): a, b and c, each gathered in one piece
    low = np.maximum(np.ceil(edges[[0, 6]].T - 0.5), 0).astype(np.int64)  # first column and row
    high = np.minimum(np.floor(edges[[1, 8]].T - 0.5), [width - 1, height - 1]).astype(np.int64)
    spans = np.maximum(high - low + 1, 0)
    bound = np.where(np.isnan(depth_plane[:, 0]), 0, spans[:, 0] * spans[:, 1])
    start, ends, count = 0, np.cumsum(bound), len(bound)
    while start < count:
        stop = max(
            int(np.searchsorted(ends, ends[start] - bound[start] + _CHUNK_SAMPLES, "right")), start + 1
        )
        chunk = np.arange(start, stop, dtype=np.int32)[bound[start:stop] > 0]
        yield _samples(edges[:, chunk], chunk, low[chunk, 1], spans[chunk, 1], planes, width)
        start = stop


def _edges(corners: np.ndarray) -> np.ndarray:
    """(10, T): per triangle, its x range, the top corner and the slope (dx/dy) of the edge from it to
    the bottom corner, the middle corner and the slopes of the edges from top to middle and middle to
    bottom, and the bottom row: ``x_min, x_max, x_top, slope_long, x_mid, slope_upper, y_top, y_mid,
    y_bottom, slope_lower`` (slopes of horizontal edges are 0: no row crosses them), one row each (so
    that each is gathered in one piece)."""
    x, y = corners[0], corners[1]
    count = x.shape[1]
    top = np.argmin(y, axis=0)  # the first lowest y; the bottom is the last largest, the middle the third
    bottom = 2 - np.argmax(y[::-1], axis=0)
    flat = np.arange(count)
    at = [top * count + flat, (3 - top - bottom) * count + flat, bottom * count + flat]
    (x_top, x_mid, x_bottom), (y_top, y_mid, y_bottom) = ([np.take(c, i) for i in at] for c in (x, y))

    def slope(x_from: np.ndarray, y_from: np.ndarray, x_to: np.ndarray, y_to: np.ndarray) -> np.ndarray:
        rise = y_to - y_from
        return np.divide(x_to - x_from, rise, out=np.zeros(count), where=rise != 0)

    return np.stack(
        [
            x.min(axis=0),
            x.max(axis=0),
            x_top,
            slope(x_top, y_top, x_bottom, y_bottom),
            x_mid,
            slope(x_top, y_top, x_mid, y_mid),
            y_top,
            y_mid,
            y_bottom,
            slope(x_mid, y_mid, x_bottom, y_bottom),
        ]
    )


def _samples(
    edges: np.ndarray,
    owners: np.ndarray,
    first_row: np.ndarray,
    rows: np.ndarray,
    planes: np.ndarray,
    width: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pixel index, triangle and depth of every pixel centre inside the given triangles (`_edges`, and
    the (3, T) rows a, b, c of every triangle's depth plane).

    Work is per row of a triangle where it can be (its span, its first pixel and depth, the depth step
    along the row), and one ``np.repeat`` per value expands the rows to their pixels.
    """
    row_of = np.repeat(np.arange(len(owners), dtype=np.int32), rows)
    y = first_row.astype(np.int32)[row_of] + _ragged(rows)
    x_min, x_max, x_top, slope_long, x_mid, slope_upper, y_top, y_mid, _, slope_lower = (
        np.take(edge, row_of) for edge in edges
    )
    centre = y + 0.5
    long_side = x_top + (centre - y_top) * slope_long
    upper = centre < y_mid
    short_side = np.where(
        upper,
        x_top + (centre - y_top) * slope_upper,
        x_mid + (centre - y_mid) * slope_lower,
    )
    left = np.clip(np.minimum(long_side, short_side), x_min, x_max)  # (rounding at the corners)
    right = np.clip(np.maximum(long_side, short_side), x_min, x_max)
    start = np.maximum(np.ceil(left - 0.5), 0).astype(np.int32)
    count = np.maximum(np.minimum(np.floor(right - 0.5), width - 1).astype(np.int32) - start + 1, 0)
    owner = owners[row_of]
    step, down, offset_depth = (np.take(plane, owner) for plane in planes)
    first_depth = step * (start + 0.5) + down * centre + offset_depth
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


def _light(nearest: np.ndarray, shade_plane: np.ndarray) -> np.ndarray:
    """The brightness (float32) at every sample of the image ``nearest`` (the triangle at each sample, -1
    for none: 0 there), from each triangle's plane of brightness."""
    planes = np.vstack([shade_plane, np.zeros((1, 3))]).astype(np.float32)  # row -1: samples of no triangle
    x = np.arange(nearest.shape[1], dtype=np.float32) + 0.5
    y = np.arange(nearest.shape[0], dtype=np.float32)[:, None] + 0.5
    light = np.take(planes[:, 0], nearest) * x + np.take(planes[:, 1], nearest) * y
    light += np.take(planes[:, 2], nearest)
    return light
