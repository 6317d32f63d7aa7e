"""Rigs and expression sequences shared by the transfer tests."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np
import pytest

import rigs
from rigs import Rig


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
    return Rig(neutral, deltas, triangles, names, meta={"source": "sheet"})


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


def _packing(rig: Rig, n_expressions: int | None = None, mu: float = 0.3) -> np.ndarray:
    """A packing-like sequence: first-fit greedy of shapes with disjoint active vertices (eq. 2).

    Largest shapes first; when every shape is placed and more expressions are wanted, further passes
    pack the shapes again (the second pass of Carrigan et al. 2020, sec. 6).
    """
    length = np.linalg.norm(rig.deltas, axis=-1)
    active = length >= mu * length.max(axis=1, keepdims=True)
    order = list(np.argsort(-active.sum(axis=1), kind="stable"))
    rows: list[np.ndarray] = []
    remaining = list(order)
    while remaining if n_expressions is None else len(rows) < n_expressions:
        if not remaining:
            remaining = list(order)
        used = np.zeros(rig.n_vertices, dtype=bool)
        row = np.zeros(rig.n_shapes)
        for shape in list(remaining):
            if not (active[shape] & used).any():
                used |= active[shape]
                row[shape] = 1.0
                remaining.remove(shape)
        rows.append(row)
    return np.array(rows).reshape(-1, rig.n_shapes)


@pytest.fixture
def sheet() -> Callable[..., Rig]:
    """Factory of sheet rigs: ``sheet(n_columns, n_rows, n_shapes, seed)``."""
    return _sheet


@pytest.fixture
def bulge() -> Callable[[np.ndarray], np.ndarray]:
    """The sheet's nonlinear warp of positions."""
    return _bulge


@pytest.fixture
def deform() -> Callable[[Rig, Callable[[np.ndarray], np.ndarray]], Rig]:
    """Apply a position map to a rig's neutral and every shape."""
    return _deform


@pytest.fixture
def packing() -> Callable[..., np.ndarray]:
    """Greedy packing-like expression weights: ``packing(rig, n_expressions=None, mu=0.3)``."""
    return _packing


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
