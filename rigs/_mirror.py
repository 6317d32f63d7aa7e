"""Vertex mirror map across a mesh's left/right symmetry plane (Carrigan et al. 2020, sec. 4.4.1)."""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from scipy.spatial import cKDTree

_AXES = {"x": 0, "y": 1, "z": 2, 0: 0, 1: 1, 2: 2}
_SAMPLE = 2048  # vertices used to fit and score candidate planes
_REFINE_STEPS = 8  # refinements of each candidate plane ...
_COARSE = 4  # ... on every fourth vertex of the sample
_FINAL_STEPS = 4  # refinements of the best plane on the sample: to nearest vertices
_SURFACE_STEPS = 10  # ... or to closest surface points
_SETTLE = 0.02  # a fit moving no reflection by more than this many vertex spacings has converged
_GATE = 4.0  # while fitting, a reflected vertex this many match radii from the mesh is an outlier
_CORE = 0.9  # share of the vertices nearest the median whose principal axes are candidate normals too
_MOVED = 0.5  # a median plane leaving more of the vertices than this in place is no candidate
_SAME = float(np.cos(np.radians(1.0)))  # normals closer than a degree are one candidate
_TIE = 0.01  # fitted planes mirroring within this share of the sample of the best count as equal
#: Default tolerance when matching to the surface, in local edge lengths (see `mirror_map`).
SURFACE_TOL = 1.0
_EXACT = 1e-9  # a reflection this many vertex spacings from a vertex lands on it
_TINY = 1e-300  # guards a division by a zero match radius
_FLAT = 1e-12  # a triangle with |ab x ac|^2 below this share of |ab|^2 |ac|^2 has zero area
_CANDIDATES = 6  # triangles with the nearest sites (`_sites`) that are candidates for a closest point
_LARGE = 2.0  # a triangle whose longest edge is more than twice the median one has several sites
_MAX_PARTS = 16  # a large triangle stands as at most this many squared sites


class _Matches(NamedTuple):
    """Where reflected points meet the mesh: distance, the point met, its vertex, the accepted distance and
    (on a surface) the unit normal of the triangle met, zero where none is."""

    distance: np.ndarray
    target: np.ndarray
    vertex: np.ndarray
    limit: np.ndarray
    normal: np.ndarray | None = None


def mirror_map(
    neutral: np.ndarray,
    *,
    axis: int | str | None = None,
    plane: tuple[np.ndarray, np.ndarray] | None = None,
    tol: float | None = None,
    triangles: np.ndarray | None = None,
) -> np.ndarray:
    """Mirror vertex of every vertex of a (nearly) symmetric mesh.

    Each vertex is reflected through the symmetry plane and matched to the mesh, as needed by shape
    symmetry (Carrigan et al. 2020, sec. 4.4.1, eq. 9). The paper derives the map from the mesh
    topology; matching positions needs no user-chosen edge and works on any mesh that is symmetric up
    to the tolerance, including scans and captures whose two halves are sampled differently.

    Parameters
    ----------
    neutral : (N, 3) float array
        Vertex positions of the neutral mesh.
    axis : {0, 1, 2, "x", "y", "z"}, optional
        The plane's normal is this coordinate axis; its offset is fitted to the mesh.
    plane : (point, normal) pair of 3-vectors, optional
        The symmetry plane itself, used as given (e.g. ``((0, 0, 0), (1, 0, 0))`` for x = 0).
    tol : float, optional
        Largest distance between a reflected vertex and the mesh for it to have a mirror. Default:
        without ``triangles``, half the median distance between a vertex and its nearest neighbour, so
        a match is unambiguous; with ``triangles``, ``SURFACE_TOL`` (1.0) times the local edge length:
        the mean edge length of the triangles touching the mirror vertex. A vertex jittered by up to
        ``a`` edge lengths lands at most ``2 a`` from the mirrored jittered surface, so the default
        accepts captures with per-vertex noise up to half an edge.
    triangles : (T, 3) int array, optional
        The mesh's triangles. When given (and not empty) a reflected vertex is matched to the closest
        point of the surface instead of the nearest vertex, and its mirror is the vertex of that
        triangle nearest to the closest point. Vertices no triangle uses are then never a mirror.

    Returns
    -------
    (N,) int64 array
        ``mirror[n]`` is the mirror vertex of vertex n, or -1 when the reflection of vertex n is
        farther than the tolerance from the mesh (these vertices have no mirror; callers report them).
        Vertices on the plane map to themselves.

    Raises
    ------
    ValueError
        If ``neutral`` is not a finite (N, 3) array, ``triangles`` is not a (T, 3) array of vertex
        indices, ``axis`` is not a coordinate axis, the plane's normal is zero, both ``axis`` and
        ``plane`` are given, or ``tol`` is negative.

    Notes
    -----
    Without ``axis`` or ``plane`` the plane is found from the neutral, on a sample of about 2048 of its
    distinct positions (seam duplicates count once). Candidate normals are the three coordinate axes,
    the principal axes of the sample and those of the 90% of it nearest its median (stray points and
    a loose part far away tilt the former, not the latter); each candidate plane goes
    through the median of the vertices' positions along its normal, which lies on the symmetry plane of
    a symmetric mesh like the centroid but is not moved by a few stray vertices.

    1. A candidate that mirrors the sample exactly (mean reflection distance within 1% of the vertex
       spacing) is taken as is, the first one in the order above, so a centred symmetric mesh yields
       x = 0 even when it is also symmetric about another plane.
    2. Otherwise every candidate is fitted to the vertex pairs it matches (nearest vertices), a few
       times: an ICP for reflections whose normal is the weighted least-squares reflection of the pairs
       (`fit_reflection_normal`) and whose offset is the median of the midpoints'. Pairs farther apart
       than four match radii are left out and the others weigh less the farther apart they are
       (Cauchy weights), so an asymmetric part or stray vertices hardly pull the plane. The fitted
       planes are ranked by the share of the sample they mirror within the match radius (counting
       only vertices the plane moves farther than that, so the plane of a flat mesh mirrors nothing);
       shares within 1% of the best count as equal and go to the earliest candidate.
    3. The best plane is fitted again on the whole sample: without ``triangles`` to the nearest vertices;
       with them to the closest surface points, by Gauss-Newton steps of the point-to-plane distances
       (`_surface_step`), which converge where the reflection slides along the surface and point pairs
       barely move it.

    This handles jittered, off-centre and rotated heads, stray vertices and loose asymmetric parts.
    Closest points on the surface are searched among the triangles of the six nearest triangle sites (a
    KD-tree query; a site is a triangle's centroid, or one of several points of a triangle much larger
    than the typical one) and measured exactly. With an exact or a given plane, a reflection that lands
    on a vertex of a triangle is matched to it directly (its own closest point). O(N log N) time.

    Examples
    --------
    >>> import numpy as np
    >>> points = np.array([[-1.0, 0, 0], [1.0, 0, 0], [0, 1.0, 0], [-2.0, 1, 0], [2.0, 1, 0]])
    >>> mirror_map(points).tolist()
    [1, 0, 2, 4, 3]

    A grid whose right half is sampled off the mirror image of the left, matched to its surface:

    >>> x, y = np.meshgrid([-2.0, -1, 0, 1.1, 2], [0.0, 1, 3])
    >>> grid = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    >>> quads = [(5 * r + c, 5 * r + c + 1, 5 * r + c + 6, 5 * r + c + 5) for r in range(2) for c in range(4)]
    >>> faces = np.array([(a, b, c) for a, b, c, _ in quads] + [(a, c, d) for a, _, c, d in quads])
    >>> mirror_map(grid, triangles=faces)[:5].tolist()
    [4, 3, 2, 1, 0]
    """
    points, faces = _checked(neutral, axis, tol, triangles)
    if axis is not None and plane is not None:
        raise ValueError("mirror_map: give either axis or plane, not both")
    sampled = _Sampled.of(points)
    vertex_tol = 0.5 * sampled.spacing if tol is None else tol
    if plane is not None:
        (origin, normal), exact, surface = _as_plane(plane), False, None
    else:
        origin, normal, exact, surface = _found_plane(points, faces, sampled, axis, tol)

    reflected = _reflect(points, origin, normal)
    if faces is None:
        distance, nearest = cKDTree(points).query(reflected)
        return np.where(distance <= vertex_tol, nearest, -1).astype(np.int64)
    mirror = np.full(points.shape[0], -1, dtype=np.int64)
    todo = np.arange(points.shape[0])
    if exact or plane is not None:  # a reflection landing on a vertex has its closest point
        used = np.flatnonzero(np.bincount(faces.ravel(), minlength=points.shape[0]))  # (as np.unique)
        distance, nearest = cKDTree(points[used]).query(
            reflected, distance_upper_bound=_within(_EXACT * sampled.spacing)
        )
        hit = np.isfinite(distance)
        mirror[hit] = used[nearest[hit]]
        todo = np.flatnonzero(~hit)
    if todo.size:
        surface = surface or _Surface(points, faces)
        found = surface.matcher(tol)(reflected[todo])
        mirror[todo] = np.where(found.distance <= found.limit, found.vertex, -1)
    return mirror


def mirror_plane(
    neutral: np.ndarray,
    *,
    axis: int | str | None = None,
    tol: float | None = None,
    triangles: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The symmetry plane that `mirror_map` finds for ``neutral``, as ``(point, unit normal)``: the plane to
    give `mirror_map` (``plane=``) for a larger mesh whose other parts should not pull it (a face's plane,
    fitted on the vertices its blendshapes move, for the whole head with a one-sided prop or hair).

    Parameters and errors are `mirror_map`'s.
    """
    points, faces = _checked(neutral, axis, tol, triangles)
    origin, normal, _, _ = _found_plane(points, faces, _Sampled.of(points), axis, tol)
    return origin, normal


def _checked(
    neutral: np.ndarray, axis: int | str | None, tol: float | None, triangles: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray | None]:
    """The neutral as a float (N, 3) array and the triangles (`_as_triangles`), checked (see `mirror_map`)."""
    points = np.asarray(neutral, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or points.shape[0] == 0:
        raise ValueError(f"mirror_map: neutral must have shape (N, 3) with N > 0, got {points.shape}")
    if not np.isfinite(points).all():
        raise ValueError("mirror_map: neutral has non-finite coordinates")
    if tol is not None and not tol >= 0:
        raise ValueError(f"mirror_map: tol must be a distance >= 0, got {tol}")
    if axis is not None and axis not in _AXES:
        raise ValueError(f"mirror_map: axis must be one of 0, 1, 2, 'x', 'y', 'z', got {axis!r}")
    return points, _as_triangles(triangles, points.shape[0])


class _Sampled(NamedTuple):
    """The distinct positions of a mesh (vertices split along UV or normal seams would otherwise weigh twice
    on one side), their KD-tree, the sample the plane is fitted on and its median vertex spacing."""

    distinct: np.ndarray
    tree: cKDTree
    sample: np.ndarray
    spacing: float

    @classmethod
    def of(cls, points: np.ndarray) -> _Sampled:
        distinct = _distinct_rows(points)
        tree = cKDTree(distinct)
        sample = distinct[:: max(1, distinct.shape[0] // _SAMPLE)]
        return cls(distinct, tree, sample, _median_spacing(tree, sample))


def _found_plane(
    points: np.ndarray, faces: np.ndarray | None, sampled: _Sampled, axis: int | str | None, tol: float | None
) -> tuple[np.ndarray, np.ndarray, bool, _Surface | None]:
    """The symmetry plane of the mesh (steps 1-3 of `mirror_map`'s notes): its point and unit normal, whether
    it mirrors the sample exactly, and the surface built on the way (None when none was needed)."""
    distinct, sample, spacing = sampled.distinct, sampled.sample, sampled.spacing
    vertex_tol = 0.5 * spacing if tol is None else tol
    candidates = [np.eye(3)[_AXES[axis]]] if axis is not None else _candidate_normals(sample)
    exact = _exact_median_plane(sampled.tree, sample, distinct, candidates, spacing)
    if exact is not None:
        return exact[0], exact[1], True, None
    # Fit every candidate to the pairs it matches, then fit the best once more.
    nearest_vertex = _vertex_matcher(sampled.tree, max(vertex_tol, spacing))
    fixed, settle = axis is not None, _SETTLE * spacing
    origin, normal = _best_fitted_plane(
        nearest_vertex, sample, distinct, candidates, fixed_normal=fixed, settle=settle
    )
    surface = None
    if faces is None:
        fit, steps = nearest_vertex, _FINAL_STEPS
    else:
        surface = _Surface(points, faces)
        fit, steps = surface.matcher(tol, at_least_local=True, reach=_GATE), _SURFACE_STEPS
    origin, normal = _refine(fit, sample, origin, normal, fixed_normal=fixed, settle=settle, steps=steps)
    return origin, normal, False, surface


def _as_triangles(triangles: np.ndarray | None, n_vertices: int) -> np.ndarray | None:
    """Validated (T, 3) int64 triangles, or None when there are none."""
    if triangles is None:
        return None
    faces = np.asarray(triangles)
    if faces.size == 0:
        return None
    if faces.ndim != 2 or faces.shape[1] != 3:
        raise ValueError(f"mirror_map: triangles must have shape (T, 3), got {faces.shape}")
    if not (np.issubdtype(faces.dtype, np.integer) or (np.isfinite(faces).all() and (faces % 1 == 0).all())):
        raise ValueError("mirror_map: triangles must hold integer vertex indices")
    faces = faces.astype(np.int64)
    if faces.min() < 0 or faces.max() >= n_vertices:
        bad = int(np.flatnonzero(((faces < 0) | (faces >= n_vertices)).any(axis=1))[0])
        raise ValueError(
            f"mirror_map: triangle {bad} {faces[bad].tolist()} indexes outside 0..{n_vertices - 1}"
        )
    return faces


def _as_plane(plane: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    try:
        origin, normal = (np.asarray(part, dtype=np.float64).reshape(3) for part in plane)
    except (TypeError, ValueError):
        raise ValueError(
            f"mirror_map: plane must be a (point, normal) pair of 3-vectors, got {plane!r}"
        ) from None
    length = float(np.linalg.norm(normal))
    if not np.isfinite(length) or length == 0 or not np.isfinite(origin).all():
        raise ValueError(f"mirror_map: plane needs a finite point and a non-zero normal, got {plane!r}")
    return origin, normal / length


def _distinct_rows(points: np.ndarray) -> np.ndarray:
    """The distinct rows of (N, 3) ``points`` in lexicographic order, as ``numpy.unique(points, axis=0)``
    gives them (a sort by the three columns, several times faster than its sort of whole rows). Of rows
    equal but for the sign of a zero, the first in that order is kept, which ``numpy.unique`` leaves open."""
    ordered = points[np.lexsort(points.T[::-1])]
    new = np.ones(len(ordered), dtype=bool)
    new[1:] = (ordered[1:] != ordered[:-1]).any(axis=1)
    return ordered[new]


def _median_spacing(tree: cKDTree, sample: np.ndarray) -> float:
    """Median distance from a vertex to its nearest other vertex (the mesh's resolution)."""
    if tree.n < 2:
        return 0.0
    distance, _ = tree.query(sample, k=2)
    positive = distance[:, 1][distance[:, 1] > 0]
    return float(np.median(positive)) if positive.size else 0.0


def _candidate_normals(points: np.ndarray) -> list[np.ndarray]:
    """Coordinate axes first (symmetric tie goes to x), then the principal axes of all points and of the
    core: the share ``_CORE`` of the points nearest their median; an axis within a degree of an earlier
    one is left out."""
    distance = np.linalg.norm(points - np.median(points, axis=0), axis=1)
    core = points[distance <= np.quantile(distance, _CORE)]
    normals = [*np.eye(3)]
    for part in (points, core):
        _, _, principal = np.linalg.svd(part - part.mean(axis=0), full_matrices=False)
        normals.extend(axis for axis in principal if all(abs(axis @ seen) < _SAME for seen in normals))
    return normals


def _reflect(points: np.ndarray, origin: np.ndarray, normal: np.ndarray) -> np.ndarray:
    return points - 2.0 * ((points - origin) @ normal)[:, None] * normal


def _median_origin(points: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """The point of the plane with unit ``normal`` that has half the vertices on each side."""
    return np.median(points @ normal) * normal


def _exact_median_plane(
    tree: cKDTree, sample: np.ndarray, points: np.ndarray, candidates: list[np.ndarray], spacing: float
) -> tuple[np.ndarray, np.ndarray] | None:
    """The first candidate plane through the median that mirrors the sample exactly (mean reflection
    distance, capped at the vertex spacing, within 1% of it), or None.

    A plane that moves fewer than half of the sample by more than the vertex spacing is skipped: it is
    the plane of a flat mesh, which maps every vertex to itself.
    """
    bound = spacing or np.inf
    for normal in candidates:
        origin = _median_origin(points, normal)
        if np.mean(2.0 * np.abs((sample - origin) @ normal) > spacing) < _MOVED:
            continue
        distance, _ = tree.query(_reflect(sample, origin, normal), distance_upper_bound=bound)
        if np.minimum(distance, bound).mean() <= 0.01 * spacing:
            return origin, normal
    return None


def _best_fitted_plane(
    matches: Callable[[np.ndarray], _Matches],
    sample: np.ndarray,
    points: np.ndarray,
    candidates: list[np.ndarray],
    *,
    fixed_normal: bool,
    settle: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Every candidate plane fitted to the pairs of part of the vertex sample (every ``_COARSE``-th
    vertex), and the one that mirrors most of the sample.

    A plane a little off the symmetry plane can score worse than another candidate on a dense mesh
    (every reflected vertex lands near some vertex); fitting each candidate first lets the true plane
    win. Ranking by the share of the sample mirrored within the match radius, not by a mean distance,
    keeps vertices without any mirror (an asymmetric part, stray points) from swaying the choice. Only
    vertices the plane moves by more than the match radius count: the plane of a flat mesh, which
    maps every vertex to itself, mirrors nothing.
    """
    coarse = sample[::_COARSE]
    fitted = [
        _refine(
            matches, coarse, _median_origin(points, normal), normal, fixed_normal=fixed_normal, settle=settle
        )
        for normal in candidates
    ]
    shares = []
    for origin, normal in fitted:
        found = matches(_reflect(sample, origin, normal))
        moved = 2.0 * np.abs((sample - origin) @ normal) > found.limit
        shares.append(np.count_nonzero(moved & (found.distance <= found.limit)) / sample.shape[0])
    shares = np.array(shares)
    return fitted[int(np.flatnonzero(shares >= shares.max() - _TIE)[0])]


def _refine(
    matches: Callable[[np.ndarray], _Matches],
    points: np.ndarray,
    origin: np.ndarray,
    normal: np.ndarray,
    *,
    fixed_normal: bool,
    settle: float,
    steps: int = _REFINE_STEPS,
) -> tuple[np.ndarray, np.ndarray]:
    """Fit the plane to the pairs (a vertex of ``points``, the mesh point its reflection meets) a few times
    (an ICP for reflections).

    A robust fit: pairs more than ``_GATE`` match radii apart are left out and the others weigh
    ``1 / (1 + (r / radius)^2)`` (Cauchy) by their distance ``r``, so pairs made by an asymmetric part or
    stray vertices hardly pull the plane. Matched to vertices, the plane is the least-squares reflection
    of the pairs (`fit_reflection_normal`; offset: the median of the midpoints'); matched to a surface, it
    takes a Gauss-Newton step of the point-to-plane distances (`_surface_step`), which, unlike
    point-to-point pairs, are not held back where the reflection slides along the surface. Stops after
    ``steps`` fits or once a fit moves no reflection by more than ``settle``.
    """
    reach = float(np.linalg.norm(points, axis=1).max())  # the plane turns about its point nearest to 0
    for _ in range(steps):
        found = matches(_reflect(points, origin, normal))
        inlier = found.distance <= _GATE * found.limit
        if np.count_nonzero(inlier) < 3:
            break
        weights = 1.0 / (1.0 + (found.distance[inlier] / np.maximum(found.limit[inlier], _TINY)) ** 2)
        source, target = points[inlier], found.target[inlier]
        if found.normal is not None:
            new_origin, new_normal = _surface_step(
                source, target, found.normal[inlier], weights, origin, normal, fixed_normal=fixed_normal
            )
        else:
            new_normal = normal if fixed_normal else fit_reflection_normal(source, target, weights, normal)
            # Only the offset along the normal is defined by the pairs: the median of the midpoints'.
            midpoints = 0.5 * (source + target) @ new_normal
            new_origin = origin + (np.median(midpoints) - origin @ new_normal) * new_normal
        # How far the step moves the reflection of any of the points, at most.
        moved = 2.0 * (
            abs(new_origin @ new_normal - origin @ normal) + np.linalg.norm(new_normal - normal) * reach
        )
        origin, normal = new_origin, new_normal
        if moved <= settle:
            break
    return origin, normal


def _surface_step(
    source: np.ndarray,
    target: np.ndarray,
    surface_normals: np.ndarray,
    weights: np.ndarray,
    origin: np.ndarray,
    normal: np.ndarray,
    *,
    fixed_normal: bool,
) -> tuple[np.ndarray, np.ndarray]:
    """One weighted Gauss-Newton step of ``sum_i w_i (nu_i . (R x_i - y_i))^2`` over the plane.

    ``R x = x - 2 s n`` with ``s = n . x - c``; the plane moves by ``n -> n + a t1 + b t2`` (``t1``, ``t2``
    spanning the plane) and ``c -> c + e``, with ``dRx/dt = -2 ((t . x) n + s t)`` and ``dRx/dc = 2 n``.
    Directions the residuals do not see (a flat patch) get no step (least-squares minimum norm).
    """
    offset = float(origin @ normal)
    side = source @ normal - offset
    reflected = source - 2.0 * side[:, None] * normal
    residual = np.einsum("ij,ij->i", surface_normals, reflected - target)
    columns = [2.0 * (surface_normals @ normal)]  # d residual / d c
    tangents = np.linalg.svd(normal[None, :])[2][1:] if not fixed_normal else np.zeros((0, 3))
    for tangent in tangents:
        columns.append(
            -2.0 * ((source @ tangent) * (surface_normals @ normal) + side * (surface_normals @ tangent))
        )
    jacobian = np.column_stack(columns) * np.sqrt(weights)[:, None]
    step = np.linalg.lstsq(jacobian, -residual * np.sqrt(weights), rcond=None)[0]
    new_normal = normal + step[1:] @ tangents if tangents.size else normal
    new_normal = new_normal / np.linalg.norm(new_normal)
    return (offset + step[0]) * new_normal, new_normal


def fit_reflection_normal(
    source: np.ndarray, target: np.ndarray, weights: np.ndarray, previous: np.ndarray
) -> np.ndarray:
    """Unit normal of the plane whose reflection takes ``source`` nearest to ``target`` (weighted least
    squares), oriented like ``previous``.

    Minimising ``sum_i w_i |y_i - R x_i|^2`` over reflections ``R x = x - 2 (n . x - c) n`` gives, after
    the optimal offset ``c = n . m`` (``m`` the weighted mean of the midpoints), ``n`` as the eigenvector
    of the smallest eigenvalue of ``B = sym(sum_i w_i x~_i y~_i^T) - W/4 (y_bar - x_bar)(y_bar - x_bar)^T``
    (``x~``, ``y~`` centred on the weighted means ``x_bar``, ``y_bar``; ``W = sum_i w_i``). Noise in the
    targets that does not depend on the sources cancels in ``B``, unlike in the principal direction of
    the chords ``x_i - y_i``, which it tilts.
    """
    total = float(weights.sum())
    source_mean, target_mean = weights @ source / total, weights @ target / total
    cross = (source - source_mean).T @ ((target - target_mean) * weights[:, None])
    shift = target_mean - source_mean
    _, vectors = np.linalg.eigh(0.5 * (cross + cross.T) - 0.25 * total * np.outer(shift, shift))
    normal = vectors[:, 0]
    return normal * np.sign(normal @ previous or 1.0)


def _vertex_matcher(tree: cKDTree, radius: float) -> Callable[[np.ndarray], _Matches]:
    """Match query points to their nearest vertex of ``tree``, accepted within ``radius``.

    Points farther than ``_GATE`` radii from every vertex (outliers of the fit) get an infinite distance:
    bounded queries stay fast when a candidate plane reflects the mesh far off itself.
    """

    def match(queries: np.ndarray) -> _Matches:
        distance, nearest = tree.query(queries, distance_upper_bound=_within(_GATE * radius))
        nearest = np.minimum(nearest, tree.n - 1)
        return _Matches(distance, tree.data[nearest], nearest, np.full(len(queries), radius))

    return match


class _Surface:
    """A triangle mesh prepared for closest-point queries, with the local edge length at each vertex."""

    def __init__(self, points: np.ndarray, triangles: np.ndarray) -> None:
        self.triangles = triangles
        self.corners = points[triangles]  # (T, 3, 3)
        self.parts = _TriangleParts.of(self.corners[:, 0], self.corners[:, 1], self.corners[:, 2])
        lengths = np.linalg.norm(self.corners - self.corners[:, [1, 2, 0]], axis=2)
        sites, self.site_triangle, self.reach = _sites(self.corners, lengths.max(axis=1))
        area = np.cross(self.parts.ab, self.parts.ac)
        size = np.linalg.norm(area, axis=1, keepdims=True)
        self.normals = np.divide(area, size, out=np.zeros_like(area), where=size > 0)
        self.sites = cKDTree(sites, balanced_tree=False)  # faster to build, as fast to query here
        flat = triangles.ravel()
        counts = np.bincount(flat, minlength=points.shape[0])
        #: Mean edge length of the triangles touching each vertex (0 for vertices no triangle uses).
        self.local = np.bincount(
            flat, weights=np.repeat(lengths.mean(axis=1), 3), minlength=points.shape[0]
        ) / np.maximum(counts, 1)

    def matcher(
        self, tol: float | None, *, at_least_local: bool = False, reach: float = 1.0
    ) -> Callable[[np.ndarray], _Matches]:
        """Match query points to the surface; accepted within ``tol``, or ``SURFACE_TOL`` local edge
        lengths without it (at least one local edge length with ``at_least_local``). Points farther
        than ``reach`` times the largest such limit from the surface get an infinite distance."""
        local_max = float(self.local.max())
        largest = SURFACE_TOL * local_max if tol is None else float(tol)
        if at_least_local:
            largest = max(largest, local_max)

        def match(queries: np.ndarray) -> _Matches:
            distance, target, vertex, triangle = self.closest(queries, reach * largest)
            local = self.local[vertex]
            limit = SURFACE_TOL * local if tol is None else np.full(len(queries), float(tol))
            limit = np.maximum(limit, local) if at_least_local else limit
            normal = np.where((triangle >= 0)[:, None], self.normals[triangle], 0.0)
            return _Matches(distance, target, vertex, limit, normal)

        return match

    def closest(
        self, queries: np.ndarray, bound: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Distance to the closest point of the surface, that point, the vertex of its triangle nearest to
        it and the triangle, for every query point; an infinite distance (and the query itself, vertex 0
        and triangle -1) for the points farther than ``bound``, maybe also for a few a little nearer.

        Candidates: the triangles of the ``_CANDIDATES`` sites (`_sites`) nearest to the point, each
        measured exactly (`closest_on_triangles`). A point within ``bound`` of a triangle is within
        ``bound + self.reach`` of one of its sites, so the points with no site that near are left out
        before any triangle is measured.
        """
        n_queries = queries.shape[0]
        k = min(_CANDIDATES, self.sites.n)
        reach, near = self.sites.query(queries, k=k, distance_upper_bound=_within(bound + self.reach))
        found, near = np.isfinite(np.reshape(reach, (n_queries, k))), np.reshape(near, (n_queries, k))
        distance = np.full(n_queries, np.inf)
        target, vertex = queries.copy(), np.zeros(n_queries, dtype=np.int64)
        triangle = np.full(n_queries, -1, dtype=np.int64)
        rows = np.flatnonzero(found[:, 0])
        rows = rows[np.argsort(near[rows, 0], kind="stable")]  # by site: gathers stay local in memory
        found, near = found[rows], near[rows]
        candidates = self.site_triangle[np.where(found, near, 0)].ravel()
        points, squared = self._measure(np.repeat(queries[rows], k, axis=0), candidates)
        squared = np.where(found.ravel(), squared, np.inf)
        best = np.arange(rows.size) * k + np.argmin(squared.reshape(rows.size, k), axis=1)
        triangle[rows], target[rows] = candidates[best], points[best]
        distance[rows] = np.sqrt(squared[best])
        offsets = self.corners[triangle[rows]] - target[rows][:, None, :]
        nearest = np.argmin(np.einsum("ijk,ijk->ij", offsets, offsets), axis=1)
        vertex[rows] = self.triangles[triangle[rows], nearest]
        return distance, target, vertex, triangle

    def _measure(self, queries: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Closest point of triangle ``triangles[i]`` to ``queries[i]`` and its squared distance."""
        points = self.parts.take(triangles).closest(queries)
        offset = points - queries
        return points, _dot(offset, offset)


def _sites(corners: np.ndarray, longest: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Points standing for the triangles in the KD-tree of closest-point candidates.

    A triangle whose longest edge is up to ``n`` times
    twice the median one (``n <= _MAX_PARTS``) is cut into ``n^2`` equal parts (a regular subdivision)
    and stands as the centroids of its parts; any other (``n = 1``) as its centroid. Every point of a
    triangle is then within ``reach`` (its longest edge over ``n``, at most) of one of its sites, so a
    large triangle next to small ones is found from anywhere near it.

    Returns
    -------
    sites : (S, 3) array
    triangle : (S,) int array
        The triangle of each site.
    reach : float
    """
    sites, owners = [], []
    typical = float(np.median(longest))
    if typical > 0:
        parts = np.clip(np.ceil(longest / (_LARGE * typical)), 1, _MAX_PARTS).astype(np.int64)
    else:
        parts = np.ones(longest.shape, dtype=np.int64)
    for n in np.unique(parts):
        which = np.flatnonzero(parts == n)
        i, j = np.indices((n, n)).reshape(2, -1)
        up, down = i + j <= n - 1, i + j <= n - 2
        u = np.concatenate([i[up] + 1 / 3, i[down] + 2 / 3]) / n
        v = np.concatenate([j[up] + 1 / 3, j[down] + 2 / 3]) / n
        weights = np.column_stack([1.0 - u - v, u, v])  # barycentric centroids of the n^2 parts
        sites.append(np.einsum("sc,tcd->tsd", weights, corners[which]).reshape(-1, 3))
        owners.append(np.repeat(which, weights.shape[0]))
    return np.concatenate(sites), np.concatenate(owners), float(np.max(longest / parts))


class _TriangleParts:
    """Triangles as rows of one table: corner ``a``, edges ``ab`` and ``ac``, their dot products and
    whether the triangle has zero area (one gather per query batch)."""

    def __init__(self, table: np.ndarray) -> None:
        self.table = table
        self.a, self.ab, self.ac = table[:, 0:3], table[:, 3:6], table[:, 6:9]
        self.ab_ab, self.ab_ac, self.ac_ac = table[:, 9], table[:, 10], table[:, 11]
        self.flat = table[:, 12] > 0

    @classmethod
    def of(cls, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> _TriangleParts:
        ab, ac = b - a, c - a
        ab_ab, ab_ac, ac_ac = _dot(ab, ab), _dot(ab, ac), _dot(ac, ac)
        area = ab_ab * ac_ac - ab_ac**2  # |ab x ac|^2 (Lagrange's identity)
        flat = area <= _FLAT * ab_ab * ac_ac
        return cls(np.column_stack([a, ab, ac, ab_ab, ab_ac, ac_ac, flat]))

    def take(self, index: np.ndarray) -> _TriangleParts:
        return _TriangleParts(self.table[index])

    def closest(self, p: np.ndarray) -> np.ndarray:
        """Closest point of each triangle to the matching row of ``p``.

        Voronoi-region test of Ericson, *Real-Time Collision Detection* (2005), sec. 5.1.5: the closest
        point is a corner, a point of an edge or the projection into the face; with ``d1 = ab . ap`` and
        ``d2 = ac . ap`` the other four dot products follow from the edges' (``d3 = d1 - ab . ab``, ...).
        """
        ap = p - self.a
        d1, d2 = _dot(self.ab, ap), _dot(self.ac, ap)
        d3, d4 = d1 - self.ab_ab, d2 - self.ab_ac
        d5, d6 = d1 - self.ab_ac, d2 - self.ac_ac
        va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
        regions = [
            (d1 <= 0) & (d2 <= 0),  # corner a
            (d3 >= 0) & (d4 <= d3),  # corner b
            (vc <= 0) & (d1 >= 0) & (d3 <= 0),  # edge ab
            (d6 >= 0) & (d5 <= d6),  # corner c
            (vb <= 0) & (d2 >= 0) & (d6 <= 0),  # edge ac
            (va <= 0) & (d4 >= d3) & (d5 >= d6),  # edge bc
        ]
        with np.errstate(divide="ignore", invalid="ignore"):  # the zero-area rows are replaced below
            on_ab, on_ac = d1 / self.ab_ab, d2 / self.ac_ac
            on_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
            total = va + vb + vc
            v = np.select(regions, [0.0, 1.0, on_ab, 0.0, 0.0, 1.0 - on_bc], default=vb / total)
            w = np.select(regions, [0.0, 0.0, 0.0, 1.0, on_ac, on_bc], default=vc / total)
        points = self.a + v[:, None] * self.ab + w[:, None] * self.ac
        if self.flat.any():
            flat = self.flat
            a, b, c = self.a[flat], self.a[flat] + self.ab[flat], self.a[flat] + self.ac[flat]
            options = np.stack([_closest_on_segments(p[flat], u, t) for u, t in ((a, b), (b, c), (c, a))])
            squared = np.einsum("sij,sij->si", options - p[flat], options - p[flat])
            points[flat] = options[np.argmin(squared, axis=0), np.arange(a.shape[0])]
        return points


def closest_on_triangles(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Closest point of triangle ``(a[i], b[i], c[i])`` to ``p[i]``, for (M, 3) arrays, vectorised.

    Voronoi-region test of Ericson, *Real-Time Collision Detection* (2005), sec. 5.1.5. Triangles of
    zero area (repeated or collinear corners) are measured as their three edges.
    """
    arrays = [np.asarray(array, dtype=np.float64) for array in (p, a, b, c)]
    return _TriangleParts.of(*arrays[1:]).closest(arrays[0])


def _closest_on_segments(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    length = _dot(ab, ab)
    t = np.clip(np.divide(_dot(p - a, ab), length, out=np.zeros_like(length), where=length > 0), 0.0, 1.0)
    return a + t[:, None] * ab


def _within(distance: float) -> float:
    """A KD-tree ``distance_upper_bound`` that keeps points at exactly ``distance``: the bound is strict
    and compared squared, so it is raised by a margin that squares to a positive number."""
    return distance * (1.0 + 1e-12) + 1e-100


def _dot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return np.einsum("ij,ij->i", u, v)
