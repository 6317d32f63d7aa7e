"""Wagner et al.'s quantitative protocol inside a cell (AnaConDaR, 2024, sec. 4.4, Fig. 10): random target
examples, and a source animation of random frames judged by the mean vertex L2 error of their retargeting.

The paper draws 5 source expressions and 5, 15 or 30 target examples at random from 250 expressions made
by blending each identity's ARKit rig with weights recorded in conversations, retargets each source
expression and measures the mean over the vertices of the L2 distance to the ground truth. Here the
expressions blend the rig's own moving shapes (none recorded in conversation ships with a rig):

- a **random example** (``--examples random``) turns on between `RANDOM_SHAPES` of them, chosen
  uniformly, at weight 1: 0/1 weights, as a scanned expression's are, so that every transfer takes them
  (EBFR needs them). Its target is the exact sum of the target's shapes (the paper's ground truth is
  linear). A cell trains on the first J of one draw of max(--j-values) examples seeded by the rig seed and
  the scan seed, so a larger J adds examples to a smaller one's.
- a **source frame** (``--frames F``) turns on as many shapes at weights drawn uniformly from
  `FRAME_WEIGHTS`, seeded by the rig seed alone: every cell of a rig and seed retargets the same frames,
  whichever its examples, so packing and random draws are judged on one animation. Its truth is the same
  blend of the target's shapes.
- a transfer retargets a frame with its ``retarget`` when it has one (`transfer.anacondar`: a frame is
  retargeted whole, as the paper does, its simulations are not linear), else as the blend of its
  transferred rig, which is the same for a linear method.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from rigs import Rig
    from transfer import Transfer

#: Fewest and most shapes a random example or frame turns on.
RANDOM_SHAPES = (3, 8)
#: Range of a frame's shape weights.
FRAME_WEIGHTS = (0.2, 1.0)
#: Streams of the seed sequence: the examples' and the frames' draws never share numbers.
_EXAMPLES, _FRAMES = 1, 2


def _expressions(rig: Rig, count: int, rng: np.random.Generator, weighted: bool) -> np.ndarray:
    """``(count, K)`` weights of random expressions over the rig's moving shapes."""
    moving = np.flatnonzero(np.abs(rig.deltas).reshape(rig.n_shapes, -1).max(axis=1) > 0)
    weights = np.zeros((count, rig.n_shapes))
    low, high = RANDOM_SHAPES
    for row in weights:
        size = min(int(rng.integers(low, high + 1)), moving.size)
        chosen = rng.choice(moving, size=size, replace=False)
        row[chosen] = rng.uniform(*FRAME_WEIGHTS, size=size) if weighted else 1.0
    return weights


def random_examples(rig: Rig, count: int, rig_seed: int, scan_seed: int) -> np.ndarray:
    """``(count, K)`` 0/1 weights of a cell's random target examples (seeded by both seeds)."""
    rng = np.random.default_rng([_EXAMPLES, rig_seed, scan_seed])
    return _expressions(rig, count, rng, weighted=False)


def source_frames(rig: Rig, count: int, rig_seed: int) -> np.ndarray:
    """``(count, K)`` weights of the source animation's frames (seeded by the rig seed alone)."""
    return _expressions(rig, count, np.random.default_rng([_FRAMES, rig_seed]), weighted=True)


def retargeted_frames(
    method: Transfer,
    template: Rig,
    target_neutral: np.ndarray,
    weights: np.ndarray,
    examples: np.ndarray,
    frames: np.ndarray,
    rig_estimate: Callable[[], np.ndarray],
) -> np.ndarray:
    """``(F, N, 3)`` displacements of the frames retargeted by ``method`` trained on the examples: its
    ``retarget`` where it has one, else the frames' blend of ``rig_estimate()``, its transferred rig."""
    retarget = getattr(method, "retarget", None)
    if retarget is not None:
        return retarget(template, target_neutral, weights, examples, frames)
    return np.tensordot(frames, rig_estimate(), axes=1)


def mean_vertex_error(estimate: np.ndarray, truth: np.ndarray) -> float:
    """The mean over frames and vertices of the L2 distance between ``(F, N, 3)`` displacements (Fig. 10's
    error, in the rig's length units)."""
    return float(np.linalg.norm(estimate - truth, axis=-1).mean())
