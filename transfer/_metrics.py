"""Transfer error against ground truth: RMS per vertex, split by coverage (Carrigan et al. 2020, sec. 5.2)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from transfer._inputs import as_float_array, check_weights


def _pair(estimate: object, truth: object) -> tuple[np.ndarray, np.ndarray]:
    estimate_array = as_float_array(estimate, "estimate")
    truth_array = as_float_array(truth, "truth")
    if truth_array.ndim != 3 or truth_array.shape[-1] != 3:
        raise ValueError(f"truth must have shape (K, N, 3), got {truth_array.shape}")
    if estimate_array.shape != truth_array.shape:
        raise ValueError(f"estimate has shape {estimate_array.shape} but truth has {truth_array.shape}")
    return estimate_array, truth_array


def rms(estimate: object, truth: object) -> float:
    """Root-mean-square vertex error ``sqrt(mean_{k,n} |est_k^n - gt_k^n|^2)``.

    Parameters
    ----------
    estimate, truth : (K, N, 3) arrays
        Delta (or absolute) blendshapes; units follow the rig.

    Returns
    -------
    float; 0.0 when there are no shapes or vertices.

    Raises
    ------
    ValueError
        When the shapes differ or values are not finite.
    """
    estimate_array, truth_array = _pair(estimate, truth)
    if estimate_array.size == 0:
        return 0.0
    return float(np.sqrt(np.mean(np.sum((estimate_array - truth_array) ** 2, axis=-1))))


@dataclass(frozen=True)
class TransferMetrics:
    """Errors of one transfer against ground truth (units of the rig).

    Attributes
    ----------
    rms : float
        RMS per vertex over all shapes.
    rms_covered : float
        The same over shapes in at least one training expression (NaN when there are none).
    rms_uncovered : float
        The same over shapes in no training expression (NaN when there are none).
    per_shape : (K,) array
        RMS per vertex of each shape, to show the worst.
    covered : (K,) bool array
        Which shapes some training expression contains.
    """

    rms: float
    rms_covered: float
    rms_uncovered: float
    per_shape: np.ndarray
    covered: np.ndarray

    @property
    def n_covered(self) -> int:
        """Number of shapes in at least one training expression."""
        return int(self.covered.sum())

    def worst(self, count: int = 5) -> np.ndarray:
        """Indices of the ``count`` shapes with the largest error, worst first."""
        return np.argsort(-self.per_shape, kind="stable")[:count]


def metrics(estimate: object, truth: object, weights: object = None) -> TransferMetrics:
    """RMS per vertex overall, for covered and uncovered shapes, and per shape.

    Parameters
    ----------
    estimate, truth : (K, N, 3) arrays
    weights : (J, K) array, optional
        The training expressions' weights; a shape is covered when its column holds a nonzero weight
        (a 1 for a packing). Omitted: no shape is covered.

    Returns
    -------
    TransferMetrics

    Raises
    ------
    ValueError
        When shapes differ or values are not finite.
    """
    estimate_array, truth_array = _pair(estimate, truth)
    n_shapes = truth_array.shape[0]
    covered = (check_weights(weights, n_shapes) != 0).any(axis=0)
    if truth_array.shape[1] == 0:
        squared = np.zeros(n_shapes)
    else:
        squared = np.mean(np.sum((estimate_array - truth_array) ** 2, axis=-1), axis=1)

    def pooled(mask: np.ndarray) -> float:
        return float(np.sqrt(squared[mask].mean())) if mask.any() else float("nan")

    return TransferMetrics(
        rms=pooled(np.ones(n_shapes, dtype=bool)) if n_shapes else 0.0,
        rms_covered=pooled(covered),
        rms_uncovered=pooled(~covered),
        per_shape=np.sqrt(squared),
        covered=covered,
    )
