"""Importance weights of blendshapes (Carrigan et al. 2020, sec. 4.3, eqs. 4-8)."""

from __future__ import annotations

import functools
import warnings
from collections.abc import Iterable
from dataclasses import dataclass
from functools import cached_property
from typing import Literal

import numpy as np
import scipy.sparse as sp

from packing._binary import active_lengths, rig_masks, sparse_masks
from packing._params import params_from
from registry import HarnessError
from rigs import Rig, bounding_box

#: How eq. 6's edge ratios become a triangle's distortion: the paper's sum, or its excess over 2.
Distortion = Literal["paper", "excess"]
DISTORTIONS: tuple[str, ...] = ("paper", "excess")


class MissingTargetWarning(UserWarning):
    """Triangle distortion (eqs. 6-7) needs a target neutral; without one its term is 0."""


def displacement_strength(norms: np.ndarray, masks: np.ndarray) -> np.ndarray:
    """``lambda_Dis`` (eq. 5): mean active displacement of each shape, normalised by its maximum.

    Parameters
    ----------
    norms : (K, N) array or sparse matrix
        Displacement lengths ``|v_k^n - v_0^n|`` (at least of the active entries, see
        `packing._binary.lengths_matrix`).
    masks : (K, N) bool array or sparse matrix
        Binary blendshapes (eq. 2).

    Returns
    -------
    (K,) array in [0, 1]; 0 for shapes without active vertices.
    """
    active = sparse_masks(masks)
    counts = np.diff(active.indptr)
    rows = np.repeat(np.arange(active.shape[0]), counts)
    total = np.bincount(rows, weights=active_lengths(norms, active), minlength=active.shape[0])
    mean = np.divide(total, counts, out=np.zeros(len(counts)), where=counts > 0)
    return _normalised(mean)


def triangle_distortion(
    template: np.ndarray,
    target: np.ndarray,
    triangles: np.ndarray,
    distortion: Distortion = "paper",
) -> np.ndarray:
    """Edge-ratio distortion ``s_t`` of every triangle between two neutrals (eq. 6).

    For triangle ``uvw`` (v its second vertex) with edge vectors ``vu = u - v`` and ``vw = w - v``,
    ``s_t = max(|vu_A|/|vu_B|, |vu_B|/|vu_A|) + max(|vw_A|/|vw_B|, |vw_B|/|vw_A|)``.

    Parameters
    ----------
    template, target : (N, 3) arrays
        The neutral of the template rig A and of the target character B (same topology).
    triangles : (T, 3) int array
    distortion : {"paper", "excess"}, default "paper"
        ``"paper"`` is eq. 6 as printed, in [2, inf). ``"excess"`` is ``s_t - 2`` (clipped at 0 against
        rounding), in [0, inf), as the authors' code computes it: eq. 7 then sums pure distortion,
        whereas eq. 6 as printed adds 2 for every touched triangle, so that ``lambda_TD`` mostly counts
        the triangles around a shape's active vertices.

    Returns
    -------
    (T,) array.

    Raises
    ------
    ValueError
        For an unknown ``distortion``.

    Notes
    -----
    A triangle with an edge shorter than ``1e-6`` of the larger bounding-box diagonal of the two neutrals
    in either of them (a collapsed edge or a sliver, common in scans and welded seams) has an unbounded
    ratio that would swamp the normalisation of eq. 7: it gets ``s_t = 0`` (left out of ``lambda_TD``) and
    a `DegenerateDistortionWarning` reports how many there are.

    Each ratio term ``max(a/b, b/a)`` is at least 1, with equality exactly when the edge keeps its
    length, so ``s_t = 2`` exactly when both edges at v keep their lengths: a congruent triangle, or one
    sheared about v (eq. 6 does not see the third edge). A similar but scaled triangle (factor
    ``c != 1``) has ``s_t = 2 max(c, 1/c) > 2``: a uniformly scaled target has excess everywhere.
    """
    if distortion not in DISTORTIONS:
        raise HarnessError(
            f"distortion must be one of {', '.join(map(repr, DISTORTIONS))}, got {distortion!r}"
        )
    scale = max(_diagonal(template), _diagonal(target)) or 1.0
    ratios, degenerate = [], np.zeros(len(triangles), dtype=bool)
    for corner in (0, 2):  # vu, then vw
        length_a = np.linalg.norm(template[triangles[:, corner]] - template[triangles[:, 1]], axis=1)
        length_b = np.linalg.norm(target[triangles[:, corner]] - target[triangles[:, 1]], axis=1)
        short = np.minimum(length_a, length_b) <= 1e-6 * scale
        degenerate |= short
        ratio = np.zeros(len(triangles))
        ratio[~short] = np.maximum(length_a[~short] / length_b[~short], length_b[~short] / length_a[~short])
        ratios.append(ratio)
    summed = ratios[0] + ratios[1]
    if distortion == "excess":
        summed = np.maximum(summed - 2.0, 0.0)
    summed[degenerate] = 0.0
    if degenerate.any():
        first = int(np.flatnonzero(degenerate)[0])
        warnings.warn(
            f"{int(degenerate.sum())} triangle(s) with a collapsed edge in the template or target neutral "
            f"(first: triangle {first} {triangles[first].tolist()}) are left out of the triangle distortion "
            "(eq. 6)",
            DegenerateDistortionWarning,
            stacklevel=2,
        )
    return summed


def _diagonal(points: np.ndarray) -> float:
    if not len(points):
        return 0.0
    low, high = bounding_box(points)
    return float(np.linalg.norm(high - low))


class DegenerateDistortionWarning(UserWarning):
    """Triangles with a collapsed edge were left out of the triangle distortion (eq. 6)."""


#: Active entries (shape, vertex) whose touched triangles `distortion_strength` gathers at once. On the
#: 2,000-shape film rig its transient is 29 MB instead of 75 MB for all shapes at once, and it takes half the
#: time (0.095 against 0.19 s: the blocks stay in the cache).
DISTORTION_ENTRIES = 1 << 19


def distortion_strength(distortion: np.ndarray, masks: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """``lambda_TD`` (eq. 7): summed distortion of the triangles with an active vertex, normalised.

    Parameters
    ----------
    distortion : (T,) array
        ``s_t`` of eq. 6.
    masks : (K, N) bool array or sparse matrix
        Binary blendshapes.
    triangles : (T, 3) int array

    Returns
    -------
    (K,) array in [0, 1].

    Notes
    -----
    ``b_k^t = b_k^u | b_k^v | b_k^w``; sparse products of the masks with the vertex-triangle incidence,
    about `DISTORTION_ENTRIES` active entries at a time, O(active vertices x triangles per vertex).
    """
    active = sparse_masks(masks)
    n_shapes, n_vertices, n_triangles = *active.shape, len(triangles)
    # Counts of active corners (at most 3) in int16: the same structure as in floats, a third less time.
    corners = sp.csr_matrix(
        (np.ones(3 * n_triangles, dtype=np.int16), (triangles.ravel(), np.repeat(np.arange(n_triangles), 3))),
        shape=(n_vertices, n_triangles),
    )
    summed = np.zeros(n_shapes)
    # A block of shapes at a time: the (K, T) touched triangles of a film-sized rig are the analysis's
    # largest transient otherwise (rows are independent, so the sums are the same).
    step = max(1, DISTORTION_ENTRIES * n_shapes // max(active.nnz, 1))
    for start in range(0, n_shapes, step):
        counts = active[start : start + step].astype(np.int16) @ corners  # active corners of each triangle
        # (each row summed in its stored order, as a bincount over its entries would)
        ones = np.ones(counts.indices.size)
        touched = sp.csr_matrix((ones, counts.indices, counts.indptr), shape=counts.shape)
        summed[start : start + step] = touched @ distortion
    return _normalised(summed)


def cosine_similarities(deltas: np.ndarray) -> np.ndarray:
    """(K, K) cosines ``dv_k . dv_r / (|dv_k| |dv_r|)`` of the flattened delta blendshapes (eq. 8).

    Rows and columns of shapes without displacement are 0.
    """
    flat = np.asarray(deltas, dtype=np.float64).reshape(len(deltas), -1)
    lengths = np.linalg.norm(flat, axis=1)
    unit = np.divide(flat, lengths[:, None], out=np.zeros_like(flat), where=lengths[:, None] > 0)
    return unit @ unit.T


def uniqueness(cosines: np.ndarray, used: np.ndarray, available: np.ndarray) -> np.ndarray:
    """``lambda_U`` (eq. 8) given the shapes already in reference expressions.

    ``U_k = (1/R) sum_{r in used} max(cos(dv_k, dv_r), 0)`` and ``lambda_U = 1 - U_k / max U`` over the
    available shapes. The paper calls the similarity a Pearson coefficient, but its formula is the
    (uncentred) cosine of the delta vectors; the formula is what is implemented.

    Parameters
    ----------
    cosines : (K, K) array
        `cosine_similarities` of the rig.
    used : (K,) bool array
        Shapes already in a reference expression (the set R).
    available : (K,) bool array
        Shapes still to be packed (the set K of Algorithm 1).

    Returns
    -------
    (K,) array in [0, 1]. All 0 before the first expression (R empty), since the first expression is
    unique by definition; 0 for shapes that are not available. When no available shape resembles a
    used one (all ``U_k = 0``), every available shape is fully unique (1).
    """
    return uniqueness_of_resemblance(np.maximum(cosines, 0.0), used, available)


def uniqueness_of_resemblance(resemblance: np.ndarray, used: np.ndarray, available: np.ndarray) -> np.ndarray:
    """`uniqueness` from the cosines already clipped at 0, ``max(cos(dv_k, dv_r), 0)`` (one
    matrix-vector product per expression)."""
    result = np.zeros(len(resemblance))
    n_used = int(np.count_nonzero(used))
    if n_used == 0 or not available.any():
        return result
    similarity = (resemblance @ used.astype(np.float64))[available] / n_used
    top = similarity.max()
    result[available] = 1.0 - similarity / top if top > 0 else 1.0
    return result


@dataclass(frozen=True, eq=False)
class ImportanceTerms:
    """The per-shape importance terms of a rig, computed once (eqs. 5, 7) and combined per expression.

    Attributes
    ----------
    displacement : (K,) array
        ``lambda_Dis`` (eq. 5).
    distortion : (K,) array
        ``lambda_TD`` (eq. 7); all 0 when ``has_target`` is False.
    has_target : bool
        Whether a target neutral was given; without one the triangle distortion is not defined.
    deltas : (K, N, 3) array
        The rig's deltas, for the cosines of eq. 8 (computed on first use).
    """

    displacement: np.ndarray
    distortion: np.ndarray
    has_target: bool
    deltas: np.ndarray

    @cached_property
    def cosines(self) -> np.ndarray:
        """(K, K) cosines of the delta blendshapes (eq. 8); O(K^2 N), computed once."""
        return cosine_similarities(self.deltas)

    @cached_property
    def resemblance(self) -> np.ndarray:
        """(K, K) cosines clipped at 0, the summands of eq. 8; computed once."""
        return np.maximum(self.cosines, 0.0)

    def combine(self, alpha: float, beta: float, used: np.ndarray, available: np.ndarray) -> np.ndarray:
        """``lambda_k = alpha lambda_Dis + (1 - alpha) lambda_TD + beta lambda_U`` (eq. 4)."""
        weights = alpha * self.displacement + (1.0 - alpha) * self.distortion
        if beta > 0:
            weights = weights + beta * uniqueness_of_resemblance(self.resemblance, used, available)
        return weights


def importance_terms(
    rig: Rig,
    masks: np.ndarray,
    norms: np.ndarray,
    target: np.ndarray | None,
    distortion: Distortion = "paper",
) -> ImportanceTerms:
    """Eqs. 5-7 for a rig whose binary blendshapes are known (``distortion``: see `triangle_distortion`)."""
    displacement = displacement_strength(norms, masks)
    if target is None:
        strength = np.zeros(rig.n_shapes)
    else:
        strength = distortion_strength(
            triangle_distortion(rig.neutral, target, rig.triangles, distortion), masks, rig.triangles
        )
    return ImportanceTerms(displacement, strength, target is not None, rig.deltas)


def target_neutral_of(rig: Rig, target: Rig | np.ndarray | None) -> np.ndarray | None:
    """The target neutral as an (N, 3) array, checked to have the template's topology."""
    if target is None:
        return None
    if isinstance(target, Rig):
        same = target.triangles.shape == rig.triangles.shape and np.array_equal(
            target.triangles, rig.triangles
        )
        if not same or target.n_vertices != rig.n_vertices:
            raise HarnessError(
                f"target rig {target.provenance.source or '?'!r} has other topology than the template "
                f"{rig.provenance.source or '?'!r}: {target.n_vertices} vertices and {target.n_triangles} "
                f"triangles against {rig.n_vertices} and {rig.n_triangles}, or different triangles"
            )
        return target.neutral
    neutral = np.asarray(target, dtype=np.float64)
    if neutral.shape != rig.neutral.shape:
        raise HarnessError(
            f"target_neutral has shape {neutral.shape}; the template rig {rig.provenance.source or '?'!r} "
            f"has {rig.n_vertices} vertices, so it must be {rig.neutral.shape} (same topology)"
        )
    if not np.isfinite(neutral).all():
        vertex = int(np.argwhere(~np.isfinite(neutral))[0, 0])
        raise HarnessError(f"target_neutral has a non-finite coordinate at vertex {vertex}")
    return neutral


def used_mask(rig: Rig, used: Iterable[str | int]) -> np.ndarray:
    """(K,) bool mask of shapes given by name (or index)."""
    used = list(used)
    try:
        index = np.fromiter(map(_positions(rig.names).__getitem__, used), dtype=np.int64, count=len(used))
    except (KeyError, TypeError):  # not only known names: one at a time, to name the bad one
        index = np.array([_shape_index(rig, shape) for shape in used], dtype=np.int64)
    mask = np.zeros(rig.n_shapes, dtype=bool)
    mask[index] = True
    return mask


def _shape_index(rig: Rig, shape: str | int) -> int:
    """Index of a shape given by name or index; a clear error for anything else."""
    if isinstance(shape, str):
        return rig.index(shape)
    if isinstance(shape, (int, np.integer)) and 0 <= shape < rig.n_shapes:
        return int(shape)
    raise HarnessError(f"used: {shape!r} is neither a blendshape name nor an index in 0..{rig.n_shapes - 1}")


@functools.lru_cache(maxsize=16)
def _positions(names: tuple[str, ...]) -> dict[str, int]:
    """Index of each blendshape name."""
    return {name: k for k, name in enumerate(names)}


def warn_missing_target(alpha: float) -> None:
    """Say that eq. 4's triangle-distortion term is 0 because no target neutral was given."""
    if alpha < 1:
        warnings.warn(
            f"no target neutral given: triangle distortion (eqs. 6-7) is 0, so importance is "
            f"{alpha:g} * displacement strength only",
            MissingTargetWarning,
            stacklevel=3,
        )


def importance(
    rig: Rig,
    target_neutral: Rig | np.ndarray | None = None,
    *,
    alpha: float = 0.5,
    beta: float = 0.0,
    used: Iterable[str | int] = (),
    mu: float = 0.3,
    noise_floor: float = 1e-6,
    distortion: Distortion = "paper",
) -> np.ndarray:
    """Importance weight ``lambda_k`` of every blendshape (Carrigan et al. 2020, eq. 4).

    ``lambda_k = alpha lambda_Dis_k + (1 - alpha) lambda_TD_k + beta lambda_U_k`` with displacement
    strength (eq. 5), triangle distortion against the target neutral (eqs. 6-7) and uniqueness with
    respect to the shapes already used (eq. 8).

    Parameters
    ----------
    rig : Rig
        The template rig A.
    target_neutral : (N, 3) array or Rig, optional
        Neutral of the target character B (same topology). Without it ``lambda_TD = 0`` and a
        `MissingTargetWarning` says so (when ``alpha < 1``).
    alpha : float in [0, 1]
    beta : float >= 0
    used : iterable of str
        Blendshapes already in reference expressions (the set R of eq. 8); ``lambda_U = 0`` when empty.
    mu : float in (0, 1]
        Threshold of the binary blendshapes (eq. 2).
    noise_floor : float
        Relative noise floor below which a shape is empty (see `PackingParams`).
    distortion : {"paper", "excess"}, default "paper"
        Triangle distortion of eq. 6 as printed (``s_t >= 2``) or its excess ``s_t - 2`` (see
        `triangle_distortion`).

    Returns
    -------
    (K,) float array. Empty shapes weigh 0; used shapes get no uniqueness term.

    Raises
    ------
    ValueError
        For parameters out of range, a target with other topology, unknown ``used`` names, or a rig
        whose every shape is empty.
    """
    params = params_from(mu=mu, alpha=alpha, beta=beta, noise_floor=noise_floor, distortion=distortion)
    target = target_neutral_of(rig, target_neutral)
    norms, empty, masks = rig_masks(rig, params.mu, params.noise_floor)
    require_nonempty(rig, empty)
    if target is None:
        warn_missing_target(params.alpha)
    used_shapes = used_mask(rig, used)
    terms = importance_terms(rig, masks, norms, target, params.distortion)
    return terms.combine(params.alpha, params.beta, used_shapes, ~used_shapes & ~empty)


def require_nonempty(rig: Rig, empty: np.ndarray) -> None:
    """Refuse a rig with nothing to pack."""
    if empty.size == 0:
        source = rig.provenance.source or "?"
        raise HarnessError(f"rig {source!r} has no blendshapes; there is nothing to pack")
    if empty.all():
        raise HarnessError(
            f"rig {rig.provenance.source or '?'!r}: every one of its {rig.n_shapes} blendshapes is empty "
            "(no displacement above the noise floor); there is nothing to pack"
        )


def _normalised(values: np.ndarray) -> np.ndarray:
    top = values.max(initial=0.0)
    return values / top if top > 0 else np.zeros_like(values)
