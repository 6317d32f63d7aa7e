"""Rigs and expression sequences shared by the transfer tests."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np
import pytest

import rigs
from rigs import Rig
from tests.transfer.packing_like import packing_weights


def _sheet(n_columns: int = 24, n_rows: int = 28, n_shapes: int = 10, seed: int = 0) -> Rig:
    """A smooth bumpy sheet with local, compactly supported bump blendshapes."""
    rng = np.random.default_rng(seed)
    x, y = np.meshgrid(np.linspace(0.0, 1.0, n_columns), np.linspace(0.0, 1.2, n_rows))
    z = 0.15 * np.exp(-((x - 0.5) ** 2 + (y - 0.6) ** 2) / 0.08) + 0.03 * np.sin(4 * x) * np.cos(3 * y)
    neutral = np.c_[x.ravel(), y.ravel(), z.ravel()]
    grid = np.arange(n_columns * n_rows).reshape(n_rows, n_columns)
    a, b, c, d = (grid[:-1, :-1].ravel(), grid[:-1, 1:].ravel(), grid[1:, :-1].ravel(), grid[1:, 1:].ravel())
    triangles = np.r_[np.c_[a, b, d], np.c_[a, d, c]]
    centres = rng.uniform([0.15, 0.15], [0.85, 1.05], (n_shapes, 2))
    radii = rng.uniform(0.12, 0.3, n_shapes)
    directions = rng.normal(size=(n_shapes, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    amplitude = rng.uniform(0.02, 0.06, n_shapes)
    distance = np.linalg.norm(neutral[None, :, :2] - centres[:, None], axis=-1) / radii[:, None]
    falloff = np.clip(1.0 - distance**2, 0.0, None) ** 3
    deltas = amplitude[:, None, None] * falloff[..., None] * directions[:, None, :]
    names = tuple(f"bump{k}" for k in range(n_shapes))
    return Rig(neutral, deltas, triangles, names, provenance=rigs.Provenance(source="sheet"))


def _bulge(positions: np.ndarray) -> np.ndarray:
    """Non-uniform scale plus a local enlargement: a smooth, invertible, nonlinear warp."""
    scaled = positions * np.array([1.3, 0.9, 1.1])
    centre = np.array([0.4 * 1.3, 0.5 * 0.9, 0.1])
    offset = scaled - centre
    radius = np.linalg.norm(offset, axis=-1, keepdims=True)
    return centre + offset * (1.0 + 0.4 * np.exp(-((radius / 0.2) ** 2)))


def _deform(rig: Rig, deformation: Callable[[np.ndarray], np.ndarray]) -> Rig:
    """The rig with ``deformation`` applied to the neutral and every shape (Carrigan et al. 2020, 5.1)."""
    neutral = deformation(rig.neutral)
    return replace(rig, neutral=neutral, deltas=deformation(rig.neutral + rig.deltas) - neutral)


@pytest.fixture(scope="session")
def sheet() -> Callable[..., Rig]:
    """Factory of sheet rigs: ``sheet(n_columns, n_rows, n_shapes, seed)``."""
    return _sheet


@pytest.fixture(scope="session")
def bulge() -> Callable[[np.ndarray], np.ndarray]:
    """The sheet's nonlinear warp of positions."""
    return _bulge


@pytest.fixture(scope="session")
def deform() -> Callable[[Rig, Callable[[np.ndarray], np.ndarray]], Rig]:
    """Apply a position map to a rig's neutral and every shape."""
    return _deform


@pytest.fixture(scope="session")
def packing() -> Callable[..., np.ndarray]:
    """Greedy packing-like expression weights: ``packing(rig, n_expressions=None, mu=0.3)``."""
    return packing_weights


@pytest.fixture(scope="session")
def tiny_pair() -> tuple[Rig, Rig]:
    """The generated ``tiny`` rig and a nonlinearly warped copy of it."""
    template = rigs.generate("tiny")
    centre = template.neutral.mean(axis=0)

    def warp(positions: np.ndarray) -> np.ndarray:
        scaled = (positions - centre) * np.array([1.2, 0.9, 1.1]) + centre
        return scaled + 0.02 * np.sin(scaled[..., [1, 2, 0]] / 3.0) * template.diagonal()

    return template, _deform(template, warp)


@pytest.fixture(scope="session")
def female_pair() -> tuple[Rig, Rig]:
    """The ``female`` preset and its ``alien`` warp (Carrigan et al. 2020, sec. 5.1)."""
    template = rigs.generate("female")
    return template, rigs.warp(template, "alien")


def _edges_of(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """``(T, 3, 2)`` edges ``[v2 - v1, v3 - v1]`` (columns) of an ``(N, 3)`` field."""
    first = points[triangles[:, 1]] - points[triangles[:, 0]]
    return np.stack((first, points[triangles[:, 2]] - points[triangles[:, 0]]), axis=2)


def _frames_of(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """``(T, 3, 3)`` frames ``[v2 - v1, v3 - v1, n / sqrt(|n|)]`` (columns), written out plainly."""
    edges = _edges_of(points, triangles)
    normal = np.cross(edges[:, :, 0], edges[:, :, 1])
    normal /= np.sqrt(np.linalg.norm(normal, axis=1, keepdims=True))
    return np.concatenate((edges, normal[:, :, None]), axis=2)


def _dense_reconstruction(
    neutral: np.ndarray, triangles: np.ndarray, edges: np.ndarray, fixed: np.ndarray, values: np.ndarray
) -> np.ndarray:
    """Minimise ``sum_t area_t tr((E_t(x) - D_t) (F_t^T F_t)^-1 (E_t(x) - D_t)^T)`` with dense algebra.

    ``edges`` is ``(T, 2, 3)`` (edge, coordinate), ``fixed`` an ``(N,)`` mask whose vertices keep ``values``
    ``(N, 3)``; the free block of the normal matrix is solved with `numpy.linalg.solve`.
    """
    n_vertices, n_triangles = neutral.shape[0], triangles.shape[0]
    operator = np.zeros((2 * n_triangles, n_vertices))
    rows = np.arange(n_triangles)
    for edge, corner in ((0, 1), (1, 2)):
        operator[2 * rows + edge, triangles[:, corner]] += 1.0
        operator[2 * rows + edge, triangles[:, 0]] -= 1.0
    weight = np.zeros((2 * n_triangles, 2 * n_triangles))
    for t in range(n_triangles):
        sides = _edges_of(neutral, triangles[[t]])[0]
        area = 0.5 * np.linalg.norm(np.cross(sides[:, 0], sides[:, 1]))
        weight[2 * t : 2 * t + 2, 2 * t : 2 * t + 2] = area * np.linalg.inv(sides.T @ sides)
    normal = operator.T @ weight @ operator
    rhs = operator.T @ weight @ edges.reshape(2 * n_triangles, 3)
    free = ~fixed
    result = np.where(fixed[:, None], values, 0.0)
    system = rhs[free] - normal[np.ix_(free, fixed)] @ values[fixed]
    result[free] = np.linalg.solve(normal[np.ix_(free, free)], system)
    return result


def _reference_step_a(
    template: Rig,
    target_neutral: np.ndarray,
    weights: np.ndarray,
    examples: np.ndarray,
    *,
    beta: float = 0.1,
    kappa: float = 0.1,
    theta: float = 2.0,
    motion_scale: str = "peak",
    static_tolerance: float = 1e-6,
) -> np.ndarray:
    """Li et al.'s step A (2010, sec. 3A) solved plainly: every triangle and shape, dense algebra.

    The template is rotated onto the target (Kabsch), the prior is ``(M(A0 + A_k) M(A0)^-1 - I) E_B``,
    each triangle's ``K x K`` normal equations are solved directly, and each shape's vertices are
    reconstructed with its static vertices held (`_dense_reconstruction`). Every shape needs a static
    vertex (no anchors here).
    """
    triangles = template.triangles
    centred = template.neutral - template.neutral.mean(axis=0)
    left, _, right = np.linalg.svd((target_neutral - target_neutral.mean(axis=0)).T @ centred)
    rotation = left @ np.diag([1.0, 1.0, np.sign(np.linalg.det(left @ right))]) @ right
    neutral, deltas = template.neutral @ rotation.T, template.deltas @ rotation.T
    inverse = np.linalg.inv(_frames_of(neutral, triangles))
    target_edges = _edges_of(target_neutral, triangles)
    n_shapes, n_triangles = deltas.shape[0], triangles.shape[0]
    prior = np.empty((n_triangles, n_shapes, 6))
    motion = np.empty((n_triangles, n_shapes))
    for k in range(n_shapes):
        gradient = _frames_of(neutral + deltas[k], triangles) @ inverse
        prior[:, k] = ((gradient - np.eye(3)) @ target_edges).transpose(0, 2, 1).reshape(-1, 6)
        motion[:, k] = np.linalg.norm(_edges_of(deltas[k], triangles).reshape(n_triangles, -1), axis=1)
    if motion_scale == "peak":
        peak = motion.max(axis=0)
        motion = motion / np.where(peak > 0, peak, 1.0)
    regularisation = ((1.0 + motion) / (kappa + motion)) ** theta
    observed = np.zeros((n_triangles, len(examples), 6))  # (T, J, edge * coordinate)
    for j, offset in enumerate(examples - target_neutral):
        observed[:, j] = _edges_of(offset, triangles).transpose(0, 2, 1).reshape(-1, 6)
    fitted = np.empty((n_triangles, n_shapes, 6))
    for t in range(n_triangles):
        damping = beta * np.diag(regularisation[t])
        rhs = weights.T @ observed[t] + damping @ prior[t]
        fitted[t] = np.linalg.solve(weights.T @ weights + damping, rhs)
    lengths = np.linalg.norm(deltas, axis=-1)
    static = lengths <= static_tolerance * lengths.max(axis=1, keepdims=True)
    assert static.any(axis=1).all(), "the reference needs a static vertex in every shape"
    return np.stack(
        [
            _dense_reconstruction(
                target_neutral, triangles, fitted[:, k].reshape(-1, 2, 3), static[k], deltas[k]
            )
            for k in range(n_shapes)
        ]
    )


@pytest.fixture(scope="session")
def dense_reconstruction() -> Callable[..., np.ndarray]:
    """The vertex solve in dense algebra: ``(neutral, triangles, edges, fixed, values) -> (N, 3)``."""
    return _dense_reconstruction


@pytest.fixture(scope="session")
def reference_step_a() -> Callable[..., np.ndarray]:
    """Example-based rigging's step A solved plainly (no set-up, memo, Woodbury or local blocks)."""
    return _reference_step_a


@pytest.fixture(scope="session")
def plain_frames() -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """Triangle frames with the scaled normal, written out plainly."""
    return _frames_of
