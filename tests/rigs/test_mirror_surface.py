"""The mirror map matched to the mirrored surface, and its robust plane fit (sec. 4.4.1)."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from hypothesis.extra.numpy import arrays
from scipy.optimize import nnls
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

import rigs
from rigs import mirror_map
from rigs._mirror import SURFACE_TOL, closest_on_triangles, fit_reflection_normal

REFLECT = np.array([-1.0, 1.0, 1.0])


@cache
def rig_of(preset: str) -> rigs.Rig:
    return rigs.generate(preset)


def exact_mirror(neutral: np.ndarray) -> np.ndarray:
    """The mirror vertex of every vertex of a mesh symmetric about x = 0 bit for bit."""
    distance, index = cKDTree(neutral).query(neutral * REFLECT)
    assert distance.max() == 0.0
    return index


def mean_edge(neutral: np.ndarray, triangles: np.ndarray) -> float:
    edges = np.unique(np.sort(triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0)
    return float(np.linalg.norm(neutral[edges[:, 0]] - neutral[edges[:, 1]], axis=1).mean())


def jittered(neutral: np.ndarray, triangles: np.ndarray, share: float, seed: int) -> np.ndarray:
    """Every vertex moved ``share`` mean edge lengths in a uniformly random direction."""
    directions = np.random.default_rng(seed).normal(size=neutral.shape)
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    return neutral + share * mean_edge(neutral, triangles) * directions


def ring_neighbours(triangles: np.ndarray, n_vertices: int) -> list[set[int]]:
    """Each vertex with the vertices it shares a triangle with."""
    neighbours = [{n} for n in range(n_vertices)]
    for a, b, c in triangles.tolist():
        neighbours[a] |= {b, c}
        neighbours[b] |= {a, c}
        neighbours[c] |= {a, b}
    return neighbours


def share_near_truth(mirror: np.ndarray, truth: np.ndarray, triangles: np.ndarray) -> float:
    """Share of vertices mapped to their true mirror vertex or a vertex sharing a triangle with it."""
    neighbours = ring_neighbours(triangles, len(truth))
    return float(np.mean([m in neighbours[t] for m, t in zip(mirror.tolist(), truth.tolist(), strict=True)]))


def sphere(centre: tuple[float, float, float], radius: float, n: int = 10) -> tuple[np.ndarray, np.ndarray]:
    """A UV sphere with its poles cut off: vertices and triangles."""
    polar, around = np.meshgrid(
        np.linspace(0.2, np.pi - 0.2, n), np.linspace(0, 2 * np.pi, n, endpoint=False)
    )
    points = np.column_stack(
        [
            np.sin(polar).ravel() * np.cos(around).ravel(),
            np.sin(polar).ravel() * np.sin(around).ravel(),
            np.cos(polar).ravel(),
        ]
    )
    cells = [(a * n + b, ((a + 1) % n) * n + b) for a in range(n) for b in range(n - 1)]
    triangles = [(p, q, q + 1) for p, q in cells] + [(p, q + 1, p + 1) for p, q in cells]
    return points * radius + np.asarray(centre), np.array(triangles)


# -- closest point on a triangle ---------------------------------------------------------------------------


def _grid_minimum(point: np.ndarray, corners: np.ndarray, steps: int = 60) -> float:
    """Smallest distance from ``point`` to a fine barycentric grid of the triangle (>= the true one)."""
    i, j = np.indices((steps + 1, steps + 1)).reshape(2, -1)
    keep = i + j <= steps
    u, v = i[keep] / steps, j[keep] / steps
    samples = (1 - u - v)[:, None] * corners[0] + u[:, None] * corners[1] + v[:, None] * corners[2]
    return float(np.linalg.norm(samples - point, axis=1).min())


def _in_triangle(point: np.ndarray, corners: np.ndarray) -> bool:
    """``point`` lies in the (possibly degenerate) triangle: a convex combination of the corners."""
    _, residual = nnls(np.vstack([corners.T, np.ones(3)]), np.append(point, 1.0))
    return bool(residual <= 1e-9)


coordinates = st.floats(-3.0, 3.0, allow_nan=False, width=64)


@settings(max_examples=150, deadline=None)
@given(
    corners=arrays(np.float64, (3, 3), elements=coordinates),
    point=arrays(np.float64, (3,), elements=coordinates),
)
def test_closest_point_is_in_the_triangle_and_no_grid_point_is_closer(corners, point):
    closest = closest_on_triangles(point[None], *(corner[None] for corner in corners))[0]
    assert _in_triangle(closest, corners)
    assert np.linalg.norm(closest - point) <= _grid_minimum(point, corners) + 1e-9


@pytest.mark.parametrize(
    ("corners", "point", "expected"),
    [
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [0.2, 0.2, 5.0], [0.2, 0.2, 0.0]),  # above the face
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [-1.0, -1.0, 0.0], [0.0, 0.0, 0.0]),  # beyond corner a
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [1.0, 1.0, 0.0], [0.5, 0.5, 0.0]),  # beyond edge bc
        ([[0, 0, 0], [2, 0, 0], [4, 0, 0]], [3.0, 1.0, 0.0], [3.0, 0.0, 0.0]),  # collinear corners
        ([[1, 1, 1], [1, 1, 1], [1, 1, 1]], [0.0, 0.0, 0.0], [1.0, 1.0, 1.0]),  # a single point
        ([[0, 0, 0], [0, 0, 0], [0, 2, 0]], [1.0, 3.0, 0.0], [0.0, 2.0, 0.0]),  # two corners coincide
    ],
)
def test_closest_point_in_each_region_and_on_degenerate_triangles(corners, point, expected):
    corners = np.asarray(corners, dtype=float)
    closest = closest_on_triangles(np.asarray([point], dtype=float), *(corner[None] for corner in corners))
    np.testing.assert_allclose(closest[0], expected, atol=1e-12)


# -- least-squares reflection --------------------------------------------------------------------------------


def _reflect(points: np.ndarray, normal: np.ndarray, offset: float) -> np.ndarray:
    return points - 2.0 * (points @ normal - offset)[:, None] * normal


@pytest.mark.parametrize("seed", range(4))
def test_reflection_fit_recovers_the_plane_of_exact_pairs(seed):
    generator = np.random.default_rng(seed)
    normal = Rotation.random(random_state=seed).apply([1.0, 0.0, 0.0])
    source = generator.normal(size=(50, 3)) * [3.0, 1.0, 0.5]
    target = _reflect(source, normal, offset=0.7)
    fitted = fit_reflection_normal(source, target, np.ones(50), previous=normal)
    np.testing.assert_allclose(fitted, normal, atol=1e-10)


def test_reflection_fit_minimises_the_weighted_squared_distances():
    generator = np.random.default_rng(5)
    source = generator.normal(size=(200, 3)) * [3.0, 2.0, 1.0]
    target = _reflect(source, np.array([1.0, 0.0, 0.0]), 0.2) + generator.normal(scale=0.2, size=(200, 3))
    weights = generator.uniform(0.1, 1.0, size=200)

    def cost(normal: np.ndarray) -> float:
        midpoint = weights @ (0.5 * (source + target)) / weights.sum()  # the optimal offset is n . midpoint
        moved = _reflect(source, normal, float(normal @ midpoint))
        return float(weights @ np.sum((moved - target) ** 2, axis=1))

    fitted = fit_reflection_normal(source, target, weights, previous=np.array([1.0, 0.0, 0.0]))
    assert fitted[0] > 0.99
    for tilt in Rotation.random(20, random_state=1).as_rotvec() * 0.02:
        assert cost(fitted) <= cost(Rotation.from_rotvec(tilt).apply(fitted)) + 1e-9


# -- mirror_map with triangles ------------------------------------------------------------------------------


@pytest.mark.parametrize("preset", ["tiny", "male", "female"])
def test_exactly_symmetric_rig_maps_exactly_on_the_surface(preset):
    rig = rig_of(preset)
    truth = exact_mirror(rig.neutral)
    assert mirror_map(rig.neutral, triangles=rig.triangles).tolist() == truth.tolist()


def _grid(xs: np.ndarray, ys: np.ndarray, start: int) -> tuple[np.ndarray, np.ndarray]:
    """A flat grid of vertices over ``xs`` x ``ys`` (z = 0) and its triangles, numbered from ``start``."""
    x, y = np.meshgrid(xs, ys)
    points = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    corner = np.array([r * len(xs) + c for r in range(len(ys) - 1) for c in range(len(xs) - 1)]) + start
    width = len(xs)
    triangles = np.vstack([np.column_stack([corner, corner + 1, corner + width + 1]),
                           np.column_stack([corner, corner + width + 1, corner + width])])  # fmt: skip
    return points, triangles


def test_a_large_triangle_next_to_small_ones_is_met_anywhere():
    # The left half is a fine grid; the right half is a fine band along the plane and then one large
    # quad. Reflections of the left grid land in the quad, some right next to the band: a search among
    # the nearest triangle centroids alone would only find the band there.
    ys = np.linspace(0.0, 1.0, 21)
    left, left_faces = _grid(np.linspace(0.05, 1.0, 20), ys, 0)
    band, band_faces = _grid(np.linspace(-0.3, -0.05, 6), ys, len(left))
    quad = np.array([[-1.0, 0, 0], [-0.3, 0, 0], [-0.3, 1, 0], [-1.0, 1, 0]])
    first = len(left) + len(band)
    quad_faces = np.array([[0, 1, 2], [0, 2, 3]]) + first
    points = np.vstack([left, band, quad])
    triangles = np.vstack([left_faces, band_faces, quad_faces])
    mirror = mirror_map(points, plane=((0, 0, 0), (1, 0, 0)), triangles=triangles, tol=1e-9)
    assert (mirror >= 0).all()
    # Each reflection in the quad goes to the corner nearest to it of a quad triangle holding it.
    for vertex in np.flatnonzero(left[:, 0] > 0.3 + 1e-9):
        image = left[vertex] * REFLECT
        allowed = set()
        for face in quad_faces:
            if _in_triangle(image, points[face]):
                distance = np.linalg.norm(points[face] - image, axis=1)
                allowed |= set(face[distance <= distance.min() + 1e-12].tolist())
        assert int(mirror[vertex]) in allowed


def test_empty_triangles_mean_nearest_vertices():
    rig = rig_of("tiny")
    noisy = jittered(rig.neutral, rig.triangles, 0.05, seed=2)
    assert mirror_map(noisy, triangles=np.zeros((0, 3), dtype=int)).tolist() == mirror_map(noisy).tolist()


@pytest.mark.parametrize(
    ("triangles", "message"),
    [
        (np.zeros((4, 2), dtype=int), r"triangles must have shape \(T, 3\), got \(4, 2\)"),
        (np.array([[0, 1, 2], [0, 1, 10**6]]), r"triangle 1 \[0, 1, 1000000\] indexes outside 0\.\.\d+"),
        (np.array([[0, 1, -1]]), r"triangle 0 \[0, 1, -1\] indexes outside"),
        (np.array([[0.0, 1.5, 2.0]]), "triangles must hold integer vertex indices"),
    ],
)
def test_bad_triangles_are_named(triangles, message):
    with pytest.raises(ValueError, match=message):
        mirror_map(rig_of("tiny").neutral, triangles=triangles)


def test_surface_matches_where_the_halves_are_sampled_differently():
    # The right half's vertices slide along the surface by 0.4 of an edge: no vertex lies at the
    # reflection of another, but every reflection lies on the mirrored surface.
    rig = rig_of("male")
    edge = mean_edge(rig.neutral, rig.triangles)
    truth = exact_mirror(rig.neutral)
    slid = rig.neutral.copy()
    right = rig.neutral[:, 0] < -1e-9
    slid[right, 1] += 0.4 * edge  # y runs along the face
    slid[right, 2] = _surface_depth(rig, slid[right])
    by_vertex = mirror_map(slid, plane=((0, 0, 0), (1, 0, 0)))
    by_surface = mirror_map(slid, plane=((0, 0, 0), (1, 0, 0)), triangles=rig.triangles)
    assert np.mean(by_vertex < 0) > 0.3
    assert (by_surface >= 0).mean() > 0.99
    assert share_near_truth(by_surface, truth, rig.triangles) > 0.99


def _surface_depth(rig: rigs.Rig, points: np.ndarray) -> np.ndarray:
    """Depth of the neutral surface under each (x, y), interpolated over the triangles."""
    from scipy.interpolate import LinearNDInterpolator

    depth = LinearNDInterpolator(rig.neutral[:, :2], rig.neutral[:, 2])(points[:, :2])
    return np.where(np.isfinite(depth), depth, points[:, 2])


def test_default_tolerance_is_a_local_edge_length():
    rig = rig_of("male")
    truth = exact_mirror(rig.neutral)
    corners = rig.neutral[rig.triangles]
    lengths = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2).mean(axis=1)
    counts = np.bincount(rig.triangles.ravel(), minlength=rig.n_vertices)
    local = np.bincount(rig.triangles.ravel(), np.repeat(lengths, 3), rig.n_vertices) / counts
    lifted = rig.neutral.copy()
    near, far = np.flatnonzero(rig.neutral[:, 0] > 1.0)[[100, 300]]  # two vertices of the left half
    lifted[near, 2] += 0.5 * SURFACE_TOL * local[truth[near]]
    lifted[far, 2] += 2.0 * SURFACE_TOL * local[truth[far]]
    plane = ((0, 0, 0), (1, 0, 0))
    mirror = mirror_map(lifted, plane=plane, triangles=rig.triangles)
    assert mirror[near] == truth[near]
    assert mirror[far] == -1
    assert mirror_map(lifted, plane=plane, triangles=rig.triangles, tol=0.0)[near] == -1
    assert mirror_map(lifted, plane=plane, triangles=rig.triangles, tol=1e3)[far] >= 0


def test_stray_vertices_are_never_a_mirror_on_the_surface():
    rig = rig_of("tiny")
    points = np.vstack([rig.neutral, rig.neutral[:3] * REFLECT])  # unreferenced copies of mirror vertices
    mirror = mirror_map(points, triangles=rig.triangles)
    assert (mirror < rig.n_vertices).all()
    assert mirror[: rig.n_vertices].tolist() == exact_mirror(rig.neutral).tolist()


# -- the robust plane: jittered captures, strays, loose parts, rigid motions --------------------------------


def _with_part(neutral, triangles, points, faces=None):
    extra = np.zeros((0, 3), dtype=int) if faces is None else faces + len(neutral)
    return np.vstack([neutral, points]), np.vstack([triangles, extra])


CAPTURES = {
    "jitter": lambda n, t: (n, t),
    "strays": lambda n, t: _with_part(n, t, np.vstack([[[1e3, 0, 0]], np.full((40, 3), 500.0)])),
    "earring": lambda n, t: _with_part(n, t, *sphere((6.5, -3.0, 1.0), 1.2)),
    "loose part": lambda n, t: _with_part(n, t, *sphere((9.0, 0.0, -2.0), 3.0, n=20)),
}


@pytest.mark.parametrize("capture", list(CAPTURES))
@pytest.mark.parametrize("moved", [False, True])
def test_plane_survives_asymmetric_captures(capture, moved):
    rig = rig_of("female")
    truth = exact_mirror(rig.neutral)
    noisy = jittered(rig.neutral, rig.triangles, 0.3, seed=7)
    points, triangles = CAPTURES[capture](noisy, rig.triangles)
    if moved:  # an off-centre, rotated head
        points = Rotation.from_euler("xyz", [20, -35, 10], degrees=True).apply(points) + [4.0, -9.0, 2.5]
    mirror = mirror_map(points, triangles=triangles)[: rig.n_vertices]
    # As good as the map through the true plane, up to 1.5% of the vertices.
    reference = mirror_map(noisy, plane=((0, 0, 0), (1, 0, 0)), triangles=rig.triangles)
    assert (mirror >= 0).mean() > 0.99
    assert (
        share_near_truth(mirror, truth, rig.triangles)
        >= share_near_truth(reference, truth, rig.triangles) - 0.015
    )


def test_plane_of_a_jittered_flat_grid_is_not_the_grid_itself():
    # Reflecting a flat mesh through its own plane maps every vertex to itself: not a symmetry plane.
    grid, triangles = _grid(np.linspace(-1, 1, 21), np.linspace(0, 1, 31) ** 1.5 * 3, 0)
    noisy = grid + np.random.default_rng(3).normal(scale=0.01, size=grid.shape)
    mirror = mirror_map(noisy, triangles=triangles)
    assert np.mean(np.abs(grid[mirror] - grid * REFLECT).max(axis=1) < 0.11) > 0.95


@pytest.mark.parametrize(
    ("points", "triangles"),
    [
        (np.array([[1.0, 2.0, 3.0]]), np.array([[0, 0, 0]])),  # one vertex, a triangle of zero size
        (np.zeros((5, 3)), np.array([[0, 1, 2], [2, 3, 4]])),  # every vertex at one place
    ],
)
def test_degenerate_meshes_map_onto_themselves(points, triangles):
    mirror = mirror_map(points, triangles=triangles)
    assert (mirror >= 0).all()
    np.testing.assert_array_equal(points[mirror], points)
