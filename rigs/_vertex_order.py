"""Telling a blendshape whose vertices are listed in another order than its neutral's from a real
expression, by how the mesh's edges change length."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from rigs._rig import RigError, RigWarning


class VertexOrder:
    """Tells a blendshape that lists the neutral's vertices in another order from a real expression.

    A shuffled vertex order passes every count check but turns each delta into the distance between two
    unrelated vertices. Its mark is that the mesh's edges, measured in the shape, change length wholesale:
    an expression stretches the edges of the region it moves and leaves the others alone (in the
    generated rigs at most 0.4 % of edges change length more than 4 times, and at most 10 % by more than
    25 %), while a shuffled order changes most edges by a factor of ten or more.

    * More than half of the edges changing length more than `PERMUTED` times: `RigError`, the order
      differs (the shape cannot be read correctly).
    * More than half changing by more than `DOUBTFUL`: `RigWarning` (a rescaled shape, or an order
      only partly shuffled), and the shape is loaded.
    * More than half of the vertices moving further than `FAR` times the neutral's bounding-box diagonal
      (edges intact: a mirrored or rotated numbering of a symmetric mesh, or another mesh's shape):
      `RigWarning`, and the shape is loaded.

    Notes
    -----
    The shares of edges are measured on at most `SAMPLE` of them, those of triangles spread evenly over
    the mesh's triangle list (a share measured on 8,192 edges is within 1.7 points of the whole mesh's,
    three standard deviations, and a shuffled order changes nearly every edge), with squared lengths
    against squared bounds: a check costs O(min(E, SAMPLE) + N) per shape, not O(E) logarithms.
    """

    PERMUTED = 4.0
    DOUBTFUL = 1.25
    FAR = 0.25
    SAMPLE = 8192

    def __init__(self, neutral: np.ndarray, triangles: np.ndarray, neutral_path: Path) -> None:
        if 3 * len(triangles) > self.SAMPLE:  # the edges of triangles spread evenly over the mesh's list
            triangles = triangles[np.linspace(0, len(triangles) - 1, self.SAMPLE // 3).astype(np.int64)]
        pairs = np.sort(triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
        keys = np.unique(pairs[:, 0] * len(neutral) + pairs[:, 1])  # (sorted as the pairs are)
        first, second = keys // len(neutral), keys % len(neutral)
        rest = _squared_lengths(neutral[first] - neutral[second])
        kept = rest > 0
        self.first, self.second = first[kept], second[kept]
        self.bounds = {
            ratio: (rest[kept] / ratio**2, rest[kept] * ratio**2) for ratio in (self.PERMUTED, self.DOUBTFUL)
        }
        self.neutral = neutral
        self.far_squared = (self.FAR * float(np.linalg.norm(np.ptp(neutral, axis=0)))) ** 2
        self.neutral_path = neutral_path

    def _share_beyond(self, squared: np.ndarray, ratio: float) -> float:
        """The share of the (sampled) edges whose length changes more than ``ratio`` times."""
        below, above = self.bounds[ratio]
        return (np.count_nonzero(squared < below) + np.count_nonzero(squared > above)) / len(self.first)

    def check(self, shape: np.ndarray, path: Path) -> None:
        """Raise or warn as the class says."""
        if not len(self.first) or np.array_equal(shape, self.neutral):
            return
        squared = _squared_lengths(shape[self.first] - shape[self.second])
        permuted = self._share_beyond(squared, self.PERMUTED)
        if permuted > 0.5:
            raise RigError(
                f"{path}: its vertices are not in the order of the neutral {self.neutral_path.name} "
                f"({permuted:.0%} of the mesh's edges change length more than {self.PERMUTED:g} times); "
                "a blendshape must list the neutral's vertices in the same order"
            )
        doubtful = self._share_beyond(squared, self.DOUBTFUL)
        far = np.count_nonzero(_squared_lengths(shape - self.neutral) > self.far_squared) / len(shape)
        if far > 0.5:
            warnings.warn(
                f"{path}: {far:.0%} of its vertices move further than {self.FAR:g} of the neutral's size "
                f"from the neutral {self.neutral_path.name} (another mesh's shape, or vertices in another "
                "order?)",
                RigWarning,
                stacklevel=4,
            )
        if doubtful > 0.5:
            warnings.warn(
                f"{path}: {doubtful:.0%} of the mesh's edges change length by more than "
                f"{self.DOUBTFUL - 1:.0%} against the neutral {self.neutral_path.name} (a rescaled shape, "
                "or vertices in another order?)",
                RigWarning,
                stacklevel=4,
            )

    def check_target(self, target: np.ndarray, path: Path) -> None:
        """Refuse another character's neutral (``--target``) whose vertices are not in this mesh's order.

        A target may be proportioned otherwise (scaled, its nose longer), so its edges are measured against
        its overall scale: the median distance of its vertices from their median point over the neutral's
        (which no reordering changes, nor a few vertices parked far away). More than half of the edges
        changing more than `PERMUTED` times against that is a `RigError`.
        """
        if not len(self.first):
            return
        scale = _spread(target) / _spread(self.neutral)
        if not scale > 0:
            raise RigError(f"{path}: every vertex of the target neutral is at one point; not a face mesh")
        ratios = _squared_lengths(target[self.first] - target[self.second]) / (
            scale * _squared_lengths(self.neutral[self.first] - self.neutral[self.second])
        )
        permuted = np.count_nonzero((ratios > self.PERMUTED**2) | (ratios < self.PERMUTED**-2)) / len(ratios)
        if permuted > 0.5:
            raise RigError(
                f"{path}: its vertices are not in the order of the rig's neutral {self.neutral_path.name} "
                f"({permuted:.0%} of the mesh's edges change length more than {self.PERMUTED:g} times "
                "against the target's overall scale); a target must be the same mesh: same topology and "
                "vertex order"
            )


def _spread(points: np.ndarray) -> float:
    """The median squared distance of the points from their (coordinate-wise) median point."""
    return float(np.median(_squared_lengths(points - np.median(points, axis=0))))


def _squared_lengths(vectors: np.ndarray) -> np.ndarray:
    return np.einsum("ij,ij->i", vectors, vectors)
