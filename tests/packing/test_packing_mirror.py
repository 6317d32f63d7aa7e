"""The vertex mirror map (rigs.mirror_map) used by shape symmetry (sec. 4.4.1)."""

from __future__ import annotations

import numpy as np
import pytest

from rigs import mirror_map, mirror_plane


def _half_cloud(seed: int = 0, n: int = 800) -> np.ndarray:
    rng = np.random.default_rng(seed)
    half = rng.normal(size=(n, 3)) * [0.6, 1.0, 0.4]
    half[:, 0] = np.abs(half[:, 0]) + 0.05
    return half


def _symmetric_cloud(seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Points symmetric about x = 0 with an extra central column, and the true map."""
    half = _half_cloud(seed)
    centre = np.column_stack([np.zeros(20), np.linspace(-2, 2, 20), np.zeros(20)])
    points = np.vstack([half, half * [-1, 1, 1], centre])
    n = len(half)
    truth = np.concatenate([np.arange(n) + n, np.arange(n), 2 * n + np.arange(20)])
    return points, truth


def _random_rotation(seed: int) -> np.ndarray:
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    return q * np.sign(np.diag(r))


def test_centred_symmetric_mesh_maps_across_x():
    points, truth = _symmetric_cloud()
    assert mirror_map(points).tolist() == truth.tolist()


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_plane_is_found_after_a_rigid_motion(seed):
    points, truth = _symmetric_cloud(seed)
    moved = points @ _random_rotation(seed).T + [0.7, -2.0, 5.0]
    assert mirror_map(moved).tolist() == truth.tolist()


@pytest.mark.parametrize("seed", [1, 2])
def test_the_plane_found_is_the_one_mirror_map_uses(seed):
    points, truth = _symmetric_cloud(seed)
    moved = points @ _random_rotation(seed).T + [0.7, -2.0, 5.0]
    origin, normal = mirror_plane(moved)
    assert np.isclose(np.linalg.norm(normal), 1.0)
    assert np.allclose((moved - origin) @ normal + (moved[truth] - origin) @ normal, 0.0, atol=1e-9)
    assert mirror_map(moved, plane=(origin, normal)).tolist() == truth.tolist()


def test_given_axis_and_given_plane():
    points, truth = _symmetric_cloud()
    shifted = points + [3.0, 0, 0]
    assert mirror_map(shifted, axis="x").tolist() == truth.tolist()
    assert mirror_map(shifted, axis=0).tolist() == truth.tolist()
    assert mirror_map(shifted, plane=((3.0, 0, 0), (2.0, 0, 0))).tolist() == truth.tolist()


def test_mesh_symmetric_about_two_planes_prefers_x():
    grid = np.stack(np.meshgrid(np.linspace(-1, 1, 9), np.linspace(-1, 1, 9), [0.0]), axis=-1).reshape(-1, 3)
    mirror = mirror_map(grid)
    assert np.allclose(grid[mirror], grid * [-1, 1, 1])


def test_vertices_without_a_mirror_are_minus_one():
    points, truth = _symmetric_cloud()
    lonely = np.vstack([points, [[1.234, 0.5, 0.1]]])
    mirror = mirror_map(lonely, axis="x")
    assert mirror[-1] == -1
    assert mirror[:-1].tolist() == truth.tolist()


def test_tolerance_decides_what_counts_as_a_mirror():
    points, truth = _symmetric_cloud()
    noisy = points.copy()
    n = len(truth) // 2 - 10
    noisy[n : 2 * n] += [0.001, 0, 0]  # the left half moved by 1e-3
    exact = mirror_map(noisy, plane=((0, 0, 0), (1, 0, 0)), tol=1e-4)
    loose = mirror_map(noisy, plane=((0, 0, 0), (1, 0, 0)), tol=1e-2)
    assert (exact[: 2 * n] == -1).all()
    assert loose.tolist() == truth.tolist()


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"axis": "w"}, "axis must be one of 0, 1, 2, 'x', 'y', 'z', got 'w'"),
        ({"axis": 0, "plane": ((0, 0, 0), (1, 0, 0))}, "either axis or plane, not both"),
        ({"plane": ((0, 0, 0), (0, 0, 0))}, "non-zero normal"),
        ({"plane": (0, 0)}, "plane must be a \\(point, normal\\) pair"),
        ({"tol": -1.0}, "tol must be a distance >= 0, got -1.0"),
    ],
)
def test_bad_arguments_are_named(kwargs, message):
    points, _ = _symmetric_cloud()
    with pytest.raises(ValueError, match=message):
        mirror_map(points, **kwargs)


def test_bad_neutral_is_refused():
    with pytest.raises(ValueError, match=r"neutral must have shape \(N, 3\)"):
        mirror_map(np.zeros((4, 2)))
    with pytest.raises(ValueError, match="non-finite"):
        mirror_map(np.array([[0.0, 0, 0], [np.nan, 0, 0]]))
