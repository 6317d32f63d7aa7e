"""Ideal training expressions of the target: its blendshapes copied with the weights (Carrigan 2020, 5.1)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from transfer._inputs import check_weights

if TYPE_CHECKING:
    from rigs import Rig


def _check_rig(rig: object, argument: str) -> Rig:
    from rigs import Rig

    if not isinstance(rig, Rig):
        raise ValueError(f"{argument} must be a rigs.Rig, got {type(rig).__name__}")
    return rig


def training_expressions(target: Rig, weights: object) -> np.ndarray:
    """The target's training expressions by copy-pasting the weights (Carrigan et al. 2020, eq. 1).

    ``x_j = B0 + sum_k W_jk (B_k - B0)``: exactly what a rig with ground truth yields; the paper's
    evaluation (sec. 5.1, "the blendshape weights ... can be copy-pasted to obtain training expressions").

    Parameters
    ----------
    target : Rig
        The target rig B with its ground-truth blendshapes.
    weights : (J, K) array
        Blendshape weights of each expression (0/1 for a packing).

    Returns
    -------
    (J, N, 3) array of absolute vertex positions.

    Raises
    ------
    ValueError
        When ``weights`` is not ``(J, K)`` for the rig's K or holds non-finite values.
    """
    target = _check_rig(target, "target")
    weight_array = check_weights(weights, target.n_shapes)
    return target.neutral + np.tensordot(weight_array, target.deltas, axes=1)
