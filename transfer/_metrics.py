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


def _shaped(estimate: object, truth: object) -> tuple[np.ndarray, np.ndarray]:
    """`_pair` without the finiteness check, which `_squares` folds into its one pass over the arrays."""
    try:
        estimate_array = np.asarray(estimate, dtype=np.float64)
        truth_array = np.asarray(truth, dtype=np.float64)
    except (TypeError, ValueError):
        return _pair(estimate, truth)
    if truth_array.ndim != 3 or truth_array.shape[-1] != 3 or estimate_array.shape != truth_array.shape:
        return _pair(estimate_array, truth_array)
    return estimate_array, truth_array


#: Float64 entries of the differences formed at once (a chunk that stays in cache).
_CHUNK_ENTRIES = 1 << 18


def _squares(estimate: object, truth: object) -> np.ndarray:
    """``(K,)`` mean over vertices of ``|est_k^n - gt_k^n|^2`` for checked shapes; 0 without vertices.

    One pass over both arrays, in chunks of shapes; a non-finite input (seen in the result) raises the
    `ValueError` of `_pair` that names it.
    """
    estimate_array, truth_array = _shaped(estimate, truth)
    n_shapes, n_vertices = truth_array.shape[:2]
    squared = np.zeros(n_shapes)
    step = max(1, _CHUNK_ENTRIES // max(3 * n_vertices, 1))
    for start in range(0, n_shapes if n_vertices else 0, step):
        part = slice(start, start + step)
        difference = estimate_array[part] - truth_array[part]
        squared[part] = np.einsum("knc,knc->k", difference, difference) / n_vertices
    if not np.isfinite(squared).all():
        _pair(estimate_array, truth_array)
    return squared


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
    squared = _squares(estimate, truth)
    return float(np.sqrt(squared.mean())) if squared.size else 0.0


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
    squared = _squares(estimate, truth)
    n_shapes = squared.size
    covered = (check_weights(weights, n_shapes) != 0).any(axis=0)

    def pooled(mask: np.ndarray) -> float:
        return float(np.sqrt(squared[mask].mean())) if mask.any() else float("nan")

    return TransferMetrics(
        rms=pooled(np.ones(n_shapes, dtype=bool)) if n_shapes else 0.0,
        rms_covered=pooled(covered),
        rms_uncovered=pooled(~covered),
        per_shape=np.sqrt(squared),
        covered=covered,
    )
