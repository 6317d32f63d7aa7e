"""Generated packing problems for conformance checks, tests and profiling (no rig needed)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from packing import PackingProblem, problem_from_incidence


def random_problem(
    n_items: int = 12,
    n_vertices: int = 40,
    *,
    seed: int = 0,
    active: tuple[int, int] = (2, 8),
    pairs: float = 0.3,
    cap: int | None = None,
) -> PackingProblem:
    """A problem with random sparse active-vertex sets.

    Parameters
    ----------
    n_items, n_vertices : int
        Items (blendshapes or symmetry pairs) and vertices.
    seed : int
        Seed of ``numpy.random.default_rng``.
    active : (int, int)
        Inclusive range of active vertices per item.
    pairs : float in [0, 1]
        Probability that an item is a symmetry pair (two shapes, weight about twice a single's).
    cap : int, optional
        Blendshapes allowed per expression (sec. 6).
    """
    rng = np.random.default_rng(seed)
    low, high = active
    if not 1 <= low <= high <= n_vertices:
        raise ValueError(f"active must satisfy 1 <= low <= high <= n_vertices, got {active} for {n_vertices}")
    sizes = rng.integers(low, high + 1, size=n_items)
    rows = [np.sort(rng.choice(n_vertices, size=int(size), replace=False)) for size in sizes]
    indptr = np.concatenate([[0], np.cumsum(sizes)])
    indices = np.concatenate(rows) if rows else np.zeros(0, np.int64)
    incidence = sp.csr_matrix((np.ones(indices.size, bool), indices, indptr), shape=(n_items, n_vertices))
    is_pair = rng.random(n_items) < pairs
    return _with_items(incidence, rng.uniform(0.05, 1.0, size=n_items), is_pair, cap)


def face_like_problem(
    n_shapes: int,
    n_vertices: int,
    *,
    seed: int = 0,
    pairs: float = 0.35,
    cap: int | None = None,
) -> PackingProblem:
    """A paper-sized problem whose active sets are discs on a face-like grid (spatially local shapes).

    Each blendshape activates the vertices of a disc of random centre and radius (small local
    shapes are common, large ones rare); a fraction ``pairs`` of them are left/right symmetry pairs
    (the disc and its mirror image, merged into one item, sec. 4.4). Weights mimic eq. 4 with
    ``beta = 0``: half mean displacement, half distortion, both in (0, 1].

    Parameters
    ----------
    n_shapes : int
        Blendshapes (a pair counts 2), as the paper's K.
    n_vertices : int
        Vertices, as the paper's N.
    """
    rng = np.random.default_rng(seed)
    side = int(np.ceil(np.sqrt(n_vertices)))
    grid = np.stack(np.meshgrid(np.linspace(-1, 1, side), np.linspace(-1, 1, side)), axis=-1).reshape(-1, 2)
    grid = grid[:n_vertices]
    n_pairs = int(round(pairs * n_shapes / 2))
    n_items = n_shapes - n_pairs
    is_pair = np.zeros(n_items, dtype=bool)
    is_pair[rng.choice(n_items, size=n_pairs, replace=False)] = True
    centres = rng.uniform(-0.9, 0.9, size=(n_items, 2))
    centres[is_pair, 0] = np.abs(centres[is_pair, 0]) + 0.05
    radii = 0.08 + 0.5 * rng.beta(1.2, 4.0, size=n_items)
    inside = np.linalg.norm(grid[None, :, :] - centres[:, None, :], axis=-1) <= radii[:, None]
    mirrored = centres * np.array([-1.0, 1.0])
    inside |= is_pair[:, None] & (np.linalg.norm(grid[None] - mirrored[:, None], axis=-1) <= radii[:, None])
    weights = 0.5 * rng.uniform(0.2, 1.0, n_items) + 0.5 * np.sqrt(radii / radii.max())
    return _with_items(sp.csr_matrix(inside), weights * np.where(is_pair, 2.0, 1.0), is_pair, cap)


def _with_items(incidence: sp.csr_matrix, weights: np.ndarray, is_pair: np.ndarray, cap: int | None):
    """Number the shapes (a pair gets two consecutive indices) and build the problem."""
    counts = np.where(is_pair, 2, 1)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(int)
    items = tuple(tuple(range(s, s + c)) for s, c in zip(starts.tolist(), counts.tolist(), strict=True))
    return problem_from_incidence(incidence, weights, items=items, cap=cap)
