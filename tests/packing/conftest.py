"""Fixtures for the packing tests: small face-like rigs with known symmetry, and a tiny exact solver."""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np
import pytest

from packing import PackingProblem, Solution, Termination
from rigs import Provenance, Rig


@dataclass(frozen=True)
class Bump:
    """A smooth local displacement: Gaussian falloff around a centre on the (x, y) face plane."""

    name: str
    centre: tuple[float, float]
    radius: tuple[float, float]
    direction: tuple[float, float, float]
    amplitude: float = 1.0


def mirrored(bump: Bump, name: str) -> Bump:
    """The bump reflected through x = 0."""
    (x, y), (dx, dy, dz) = bump.centre, bump.direction
    return Bump(name, (-x, y), bump.radius, (-dx, dy, dz), bump.amplitude)


def face_rig(
    bumps: list[Bump],
    *,
    side: int = 41,
    regions: dict[str, tuple[tuple[float, float], tuple[float, float]]] | None = None,
    jitter: float = 0.0,
    seed: int = 0,
) -> Rig:
    """A curved square 'face' of side x side vertices over [-1, 1]^2, symmetric about x = 0.

    ``regions`` maps a name to an axis-aligned box ((x0, x1), (y0, y1)) of vertices.
    """
    xs = np.linspace(-1.0, 1.0, side)
    x, y = (a.ravel() for a in np.meshgrid(xs, xs, indexing="xy"))
    z = 0.3 * (1 - x**2) - 0.1 * y**2 + 0.05 * y**3  # symmetric about x = 0 only
    neutral = np.column_stack([x, y, z])
    grid = np.arange(side * side).reshape(side, side)
    a, b, c, d = grid[:-1, :-1].ravel(), grid[:-1, 1:].ravel(), grid[1:, :-1].ravel(), grid[1:, 1:].ravel()
    triangles = np.concatenate([np.column_stack([a, b, d]), np.column_stack([a, d, c])])
    rng = np.random.default_rng(seed)
    deltas = []
    for bump in bumps:
        (cx, cy), (rx, ry) = bump.centre, bump.radius
        falloff = np.exp(-(((x - cx) / rx) ** 2 + ((y - cy) / ry) ** 2))
        falloff[falloff < 1e-3] = 0.0
        direction = np.asarray(bump.direction, dtype=float)
        delta = bump.amplitude * falloff[:, None] * direction / np.linalg.norm(direction)
        if jitter:
            delta = delta + jitter * rng.normal(size=delta.shape) * (falloff[:, None] > 0)
        deltas.append(delta)
    boxes = regions or {}
    region_indices = {
        name: np.flatnonzero((x >= x0) & (x <= x1) & (y >= y0) & (y <= y1))
        for name, ((x0, x1), (y0, y1)) in boxes.items()
    }
    return Rig(
        neutral=neutral,
        deltas=np.array(deltas).reshape(len(bumps), -1, 3),
        triangles=triangles,
        names=tuple(bump.name for bump in bumps),
        regions=region_indices,
        provenance=Provenance(source="face_rig"),
    )


FACE_REGIONS = {
    "upper_lip": ((-0.45, 0.45), (-0.55, -0.42)),
    "lower_lip": ((-0.45, 0.45), (-0.75, -0.58)),
    "upper_eyelid_L": ((-0.75, -0.25), (0.42, 0.55)),
    "lower_eyelid_L": ((-0.75, -0.25), (0.2, 0.33)),
    "upper_eyelid_R": ((0.25, 0.75), (0.42, 0.55)),
    "lower_eyelid_R": ((0.25, 0.75), (0.2, 0.33)),
}


def standard_face(side: int = 41, jitter: float = 0.0, seed: int = 0) -> tuple[Rig, dict]:
    """A face with mirror pairs, self-symmetric shapes, lip motion pairs, an empty shape; and its truth."""
    brow = Bump("browUp_R", (0.5, 0.8), (0.18, 0.08), (0.0, 1.0, 0.2))
    cheek = Bump("cheekPuff_R", (0.6, -0.2), (0.15, 0.15), (0.3, 0.0, 1.0))
    smile = Bump("mouthSmile_R", (0.42, -0.5), (0.1, 0.1), (0.6, 0.7, 0.1))
    squint = Bump("eyeSquint_R", (0.5, 0.1), (0.12, 0.06), (0.0, 1.0, 0.0), 0.6)
    bumps = [
        brow,
        mirrored(brow, "browUp_L"),
        cheek,
        mirrored(cheek, "cheekPuff_L"),
        smile,
        mirrored(smile, "mouthSmile_L"),
        squint,
        mirrored(squint, "eyeSquint_L"),
        Bump("noseWrinkle", (0.0, 0.0), (0.1, 0.12), (0.0, 1.0, 0.3), 0.5),
        Bump("jawForward", (0.0, -0.9), (0.4, 0.08), (0.0, 0.0, 1.0), 1.2),
        Bump("upperLipUp", (0.0, -0.48), (0.25, 0.03), (0.0, 1.0, 0.05), 0.4),
        Bump("lowerLipDown", (0.0, -0.66), (0.25, 0.03), (0.0, -1.0, -0.05), 0.5),
        Bump("browDown_R", (0.35, 0.75), (0.1, 0.08), (-0.3, -1.0, 0.0), 0.7),
        Bump("empty", (0.0, 0.0), (0.1, 0.1), (0.0, 0.0, 1.0), 0.0),
    ]
    truth = {
        "mirror_pairs": [
            ("browUp_L", "browUp_R"),
            ("cheekPuff_L", "cheekPuff_R"),
            ("mouthSmile_L", "mouthSmile_R"),
            ("eyeSquint_L", "eyeSquint_R"),
        ],
        "motion_pairs": [("upperLipUp", "lowerLipDown")],
        "self_symmetric": ["noseWrinkle", "jawForward", "upperLipUp", "lowerLipDown"],
    }
    return face_rig(bumps, side=side, regions=FACE_REGIONS, jitter=jitter, seed=seed), truth


class ExactSolver:
    """Exhaustive branch and bound over the presolved conflict sets (small problems only)."""

    name = "test-exact"

    def __init__(self) -> None:
        self.calls = 0

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Solution:
        self.calls += 1
        start = time.perf_counter()
        conflicts = [set() for _ in range(problem.n_items)]
        for clique in problem.cliques:
            for a, b in itertools.combinations(clique.tolist(), 2):
                conflicts[a].add(b)
                conflicts[b].add(a)
        items, value = best_packing(problem.weights, conflicts, problem.item_shape_counts, problem.cap)
        return Solution(
            items=tuple(items),
            shapes=problem.shapes_of(items),
            objective=value,
            bound=value,
            termination=Termination.OPTIMAL,
            solve_time=time.perf_counter() - start,
            backend=self.name,
        )


def best_packing(
    weights: np.ndarray, conflicts: list[set[int]], sizes: np.ndarray, cap: int | None
) -> tuple[list[int], float]:
    """Maximum-weight set of pairwise non-conflicting items within the cap, by branch and bound."""
    order = sorted(range(len(weights)), key=lambda i: -weights[i])
    best: tuple[float, list[int]] = (0.0, [])
    suffix = np.concatenate([np.cumsum(np.maximum(weights[order][::-1], 0))[::-1], [0.0]])

    def search(position: int, chosen: list[int], value: float, used: int, blocked: frozenset[int]) -> None:
        nonlocal best
        if value > best[0]:
            best = (value, list(chosen))
        if position == len(order) or value + suffix[position] <= best[0]:
            return
        item = order[position]
        if item not in blocked and (cap is None or used + sizes[item] <= cap):
            chosen.append(item)
            search(
                position + 1,
                chosen,
                value + weights[item],
                used + int(sizes[item]),
                blocked | conflicts[item],
            )
            chosen.pop()
        search(position + 1, chosen, value, used, blocked)

    search(0, [], 0.0, 0, frozenset())
    return sorted(best[1]), float(best[0])


@pytest.fixture
def face() -> tuple[Rig, dict]:
    """The standard small face rig and its symmetry truth."""
    return standard_face()


@pytest.fixture
def kit() -> SimpleNamespace:
    """The rig builders and the brute-force packer, for tests that need more than the standard face."""
    return SimpleNamespace(
        Bump=Bump,
        mirrored=mirrored,
        face_rig=face_rig,
        standard_face=standard_face,
        best_packing=best_packing,
        ExactSolver=ExactSolver,
        FACE_REGIONS=FACE_REGIONS,
    )


@pytest.fixture
def exact_solver() -> ExactSolver:
    return ExactSolver()
