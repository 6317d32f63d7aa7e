"""Vertex mirror map across a mesh's left/right symmetry plane (Carrigan et al. 2020, sec. 4.4.1)."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

_AXES = {"x": 0, "y": 1, "z": 2, 0: 0, 1: 1, 2: 2}
_SAMPLE = 2048  # vertices used to score candidate planes
_REFINE_STEPS = 4
_MATCH_RADII = 4.0  # a reflected vertex this many radii from its nearest vertex is a miss when fitting


def mirror_map(
    neutral: np.ndarray,
    *,
    axis: int | str | None = None,
    plane: tuple[np.ndarray, np.ndarray] | None = None,
    tol: float | None = None,
) -> np.ndarray:
    """Mirror vertex of every vertex of a (nearly) symmetric mesh.

    Each vertex is reflected through the symmetry plane and matched to the nearest vertex of the mesh
    (a KD-tree query), as needed by shape symmetry (Carrigan et al. 2020, sec. 4.4.1, eq. 9). The
    paper derives the map from the mesh topology; matching positions needs no user-chosen edge and
    works on any mesh that is symmetric up to ``tol``.

    Parameters
    ----------
    neutral : (N, 3) float array
        Vertex positions of the neutral mesh.
    axis : {0, 1, 2, "x", "y", "z"}, optional
        The plane's normal is this coordinate axis; its offset is fitted to the mesh.
    plane : (point, normal) pair of 3-vectors, optional
        The symmetry plane itself, used as given (e.g. ``((0, 0, 0), (1, 0, 0))`` for x = 0).
    tol : float, optional
        Largest distance between a reflected vertex and its mirror. Default: half the median
        distance between a vertex and its nearest neighbour, so a match is unambiguous.

    Returns
    -------
    (N,) int64 array
        ``mirror[n]`` is the vertex nearest to the reflection of vertex n, or -1 when no vertex lies
        within ``tol`` (these vertices have no mirror; callers report them). Vertices on the plane
        map to themselves.

    Raises
    ------
    ValueError
        If ``neutral`` is not a finite (N, 3) array, ``axis`` is not a coordinate axis, the plane's
        normal is zero, both ``axis`` and ``plane`` are given, or ``tol`` is negative.

    Notes
    -----
    Without ``axis`` or ``plane`` the plane is found from the neutral: planes normal to the three
    coordinate axes and the three principal axes, each through the median of the vertices'
    positions along its normal, are scored by the mean reflection distance of a vertex sample (the
    first exact one ends the search). The median lies on the symmetry plane of a symmetric mesh, like
    the centroid, but a few stray vertices (unreferenced points, a loose part far away) do not move
    it. Scores within 1% of the
    vertex spacing of the best count as equal and go to the earliest candidate (x, y, z, then the
    principal axes), so a centred symmetric mesh yields x = 0 even when it is also symmetric about
    another plane. A plane that is not exact is refined by fitting it to the vertex pairs it matches
    (normal: principal direction of ``x_n - x_mirror(n)``; point: median of the midpoints), which
    handles off-centre and rotated heads. O(N log N) time.

    Examples
    --------
    >>> import numpy as np
    >>> points = np.array([[-1.0, 0, 0], [1.0, 0, 0], [0, 1.0, 0], [-2.0, 1, 0], [2.0, 1, 0]])
    >>> mirror_map(points).tolist()
    [1, 0, 2, 4, 3]
    """
    points = np.asarray(neutral, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or points.shape[0] == 0:
        raise ValueError(f"mirror_map: neutral must have shape (N, 3) with N > 0, got {points.shape}")
    if not np.isfinite(points).all():
        raise ValueError("mirror_map: neutral has non-finite coordinates")
    if axis is not None and plane is not None:
        raise ValueError("mirror_map: give either axis or plane, not both")
    if tol is not None and not tol >= 0:
        raise ValueError(f"mirror_map: tol must be a distance >= 0, got {tol}")

    tree = cKDTree(points)
    # The plane is fitted to the distinct positions: vertices split along UV or normal seams would
    # otherwise weigh twice on one side.
    distinct = np.unique(points, axis=0)
    distinct_tree = tree if len(distinct) == len(points) else cKDTree(distinct)
    sample = distinct[:: max(1, distinct.shape[0] // _SAMPLE)]
    spacing = _median_spacing(distinct_tree, sample)
    if tol is None:
        tol = 0.5 * spacing

    if plane is not None:
        origin, normal = _as_plane(plane)
    else:
        if axis is not None:
            if axis not in _AXES:
                raise ValueError(f"mirror_map: axis must be one of 0, 1, 2, 'x', 'y', 'z', got {axis!r}")
            candidates = [np.eye(3)[_AXES[axis]]]
        else:
            candidates = _candidate_normals(distinct)
        origin, normal, score = _best_plane(distinct_tree, sample, distinct, candidates, spacing)
        if score > 0.01 * spacing:  # not exactly symmetric about the median plane: fit it to the pairs
            radius, fixed_normal = max(tol, spacing), axis is not None
            origin, normal = _best_refined_plane(
                distinct_tree, sample, distinct, candidates, tol, radius, fixed_normal=fixed_normal
            )
            origin, normal = _refine(
                distinct_tree, distinct, origin, normal, radius, fixed_normal=fixed_normal
            )

    distance, nearest = tree.query(_reflect(points, origin, normal))
    nearest = nearest.astype(np.int64)
    nearest[distance > tol] = -1
    return nearest


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


def _median_spacing(tree: cKDTree, sample: np.ndarray) -> float:
    """Median distance from a vertex to its nearest other vertex (the mesh's resolution)."""
    if tree.n < 2:
        return 0.0
    distance, _ = tree.query(sample, k=2)
    positive = distance[:, 1][distance[:, 1] > 0]
    return float(np.median(positive)) if positive.size else 0.0


def _candidate_normals(points: np.ndarray) -> list[np.ndarray]:
    """Coordinate axes first (symmetric tie goes to x), then the principal axes of the point cloud."""
    centred = points - points.mean(axis=0)
    _, _, principal = np.linalg.svd(centred, full_matrices=False)
    return [*np.eye(3), *principal]


def _reflect(points: np.ndarray, origin: np.ndarray, normal: np.ndarray) -> np.ndarray:
    return points - 2.0 * ((points - origin) @ normal)[:, None] * normal


def _reflection_distances(
    tree: cKDTree, points: np.ndarray, origin: np.ndarray, normal: np.ndarray, bound: float
) -> np.ndarray:
    """Distance from each reflected point to the mesh, capped at ``bound`` (capping keeps queries cheap)."""
    distance, _ = tree.query(_reflect(points, origin, normal), distance_upper_bound=bound)
    return np.minimum(distance, bound)


def _best_plane(
    tree: cKDTree, sample: np.ndarray, points: np.ndarray, candidates: list[np.ndarray], spacing: float
) -> tuple[np.ndarray, np.ndarray, float]:
    """The candidate plane (through the median, `_median_origin`) with the smallest mean reflection
    distance of the sample, and that distance.

    Scores within 1% of the vertex spacing of the best count as equal and go to the earliest candidate;
    an exactly symmetric candidate ends the search.
    """
    bound = 0.1 * float(np.linalg.norm(np.ptp(sample, axis=0))) or np.inf
    scores = []
    origins = [_median_origin(points, normal) for normal in candidates]
    for origin, normal in zip(origins, candidates, strict=True):
        scores.append(_reflection_distances(tree, sample, origin, normal, bound).mean())
        if scores[-1] <= 0.01 * spacing:
            break
    scores = np.array(scores)
    best = int(np.flatnonzero(scores <= scores.min() + 0.01 * spacing)[0])
    return origins[best], candidates[best], float(scores[best])


def _median_origin(points: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """The point of the plane with unit ``normal`` that has half the vertices on each side."""
    return np.median(points @ normal) * normal


def _best_refined_plane(
    tree: cKDTree,
    sample: np.ndarray,
    points: np.ndarray,
    candidates: list[np.ndarray],
    tol: float,
    radius: float,
    *,
    fixed_normal: bool,
) -> tuple[np.ndarray, np.ndarray]:
    """Every candidate plane fitted to the pairs of the vertex sample, and the one that mirrors most of it.

    A plane a little off the symmetry plane can score worse than another candidate on a dense mesh
    (every reflected vertex lands near some vertex); fitting each candidate first lets the true plane
    win. The fitted planes are ranked by how many sample vertices find a mirror within ``tol``, which
    vertices without any mirror (an asymmetric part, stray points) do not sway; ties go to the earliest
    candidate.
    """
    fitted = [
        _refine(tree, sample, _median_origin(points, normal), normal, radius, fixed_normal=fixed_normal)
        for normal in candidates
    ]
    matched = [
        np.count_nonzero(tree.query(_reflect(sample, origin, normal), distance_upper_bound=tol)[0] <= tol)
        for origin, normal in fitted
    ]
    return fitted[int(np.argmax(matched))]


def _refine(
    tree: cKDTree,
    points: np.ndarray,
    origin: np.ndarray,
    normal: np.ndarray,
    radius: float,
    *,
    fixed_normal: bool,
) -> tuple[np.ndarray, np.ndarray]:
    """Fit the plane to the pairs (a vertex of ``points``, its nearest vertex of the tree) it matches, a few
    times (an ICP for reflections); ``points`` may be a sample of the tree's vertices."""
    for _ in range(_REFINE_STEPS):
        distance, nearest = tree.query(_reflect(points, origin, normal))
        matched = distance <= _MATCH_RADII * radius
        if np.count_nonzero(matched) < 3:
            break
        source, target = points[matched], tree.data[nearest[matched]]
        midpoints = 0.5 * (source + target)
        new_normal = normal
        if not fixed_normal:
            chords = source - target
            chords = chords[np.linalg.norm(chords, axis=1) > 0]
            if chords.shape[0] >= 3:
                _, _, directions = np.linalg.svd(chords, full_matrices=False)
                new_normal = directions[0] * np.sign(directions[0] @ normal or 1.0)
        # Only the offset along the normal is defined by the pairs: the median of the midpoints'.
        new_origin = origin + (np.median(midpoints @ new_normal) - origin @ new_normal) * new_normal
        converged = np.allclose(new_normal, normal, atol=1e-12) and np.allclose(
            new_origin, origin, atol=1e-12
        )
        origin, normal = new_origin, new_normal
        if converged:
            break
    return origin, normal
