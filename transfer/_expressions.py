"""Training expressions of the target: copied weights or a warped template expression (Carrigan 2020, 5.1)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from rigs import Rig, warp
from transfer._inputs import as_float_array, check_weights


def _check_rig(rig: object, argument: str) -> Rig:
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


def scan_expressions(
    template: Rig, weights: object, deformation: Callable[[np.ndarray], np.ndarray] | Any
) -> np.ndarray:
    """Scan-like training expressions: the template expression itself, deformed into the target.

    The template expression ``A0 + sum_k W_jk A_k`` is mapped through the deformation that makes the
    target from the template. Unlike `training_expressions`, the result is not a linear combination of
    the target's blendshapes (a warp is nonlinear), which is closer to a real scan of the actor.

    Parameters
    ----------
    template : Rig
        The template rig A.
    weights : (J, K) array
        Blendshape weights of each expression.
    deformation : callable or warp spec
        Either a function mapping ``(M, 3)`` positions to ``(M, 3)`` positions, applied to each
        expression, or anything `rigs.warp` accepts as a spec (e.g. ``"alien"``); the spec is then
        applied to a rig whose neutral is the template's and whose shapes are the expressions, so the
        warp is set up exactly as for the target rig.

    Returns
    -------
    (J, N, 3) array of absolute vertex positions.

    Raises
    ------
    ValueError
        On bad ``weights``, or when the deformation returns positions of another shape or non-finite ones.
    """
    template = _check_rig(template, "template")
    weight_array = check_weights(weights, template.n_shapes)
    offsets = np.tensordot(weight_array, template.deltas, axes=1)
    if callable(deformation):
        warped = [np.asarray(deformation(template.neutral + offset), dtype=np.float64) for offset in offsets]
        result = np.stack(warped) if warped else np.zeros((0, template.n_vertices, 3))
    else:
        names = tuple(f"expression_{j}" for j in range(len(offsets)))
        expressions = replace(template, deltas=offsets, names=names)
        warped_rig = warp(expressions, deformation)
        result = warped_rig.neutral + warped_rig.deltas
    result = as_float_array(result, "deformation result")
    if result.shape != offsets.shape:
        raise ValueError(f"deformation must map (N, 3) positions to (N, 3), got {result.shape[1:]}")
    return result
