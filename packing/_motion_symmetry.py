"""Motion symmetry: pairs of shapes moving sketched region pairs in opposite directions (Carrigan et al.
2020, eqs. 11-12, sec. 4.4.2)."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import scipy.sparse as sp

from packing._binary import sparse_masks
from packing._params import DEFAULT_REGION_PAIRS, PackingParams
from packing._shape_symmetry import match_pairs
from registry import HarnessError
from rigs import Rig, read_regions, regions_from_mapping


def motion_symmetry(
    deltas: np.ndarray,
    masks: np.ndarray,
    regions: Mapping[str, np.ndarray],
    region_pairs: tuple[tuple[str, str], ...],
    eligible: np.ndarray,
    cos_threshold: float = -0.985,
    share: float = 0.5,
) -> list[tuple[int, int, float]]:
    """Motion pairs from sketched region pairs (Carrigan et al. 2020, eqs. 11-12).

    A candidate of region r has at least ``share`` of its active vertices in r and none in any other
    sketched region (the paper drops shapes touching no sketch or more than one; the share keeps
    broad shapes that merely graze a sketch out). Its mean active direction is
    ``dv_k = sum_n b_k^n dv_k^n / |sum_n b_k^n dv_k^n|`` (eq. 11). A candidate of one region and one of
    the other region of the same pair are symmetric when ``cos(phi_km) = dv_k . dv_m`` is below
    ``cos_threshold`` (eq. 12); the pairs with the smallest angle between ``dv_k`` and ``-dv_m``
    (lowest cosine) are taken first and each shape joins at most one pair.

    Parameters
    ----------
    deltas : (K, N, 3) array
    masks : (K, N) bool array or sparse matrix
    regions : mapping of region name to vertex indices
        Must hold every name of ``region_pairs``.
    region_pairs : tuple of (str, str)
    eligible : (K,) bool array
        Shapes that may be paired (non-empty, not already in a mirror pair).
    cos_threshold, share : float

    Returns
    -------
    list of (k, m, cosine), k from the first region of its pair.
    """
    names = list(dict.fromkeys(name for pair in region_pairs for name in pair))
    if not names:
        return []
    active = sparse_masks(masks)
    inside = np.zeros((active.shape[1], len(names)))
    for column, name in enumerate(names):
        inside[regions[name], column] = 1.0
    counts = active.astype(np.float64) @ inside  # (K, regions): active vertices in each region
    n_active = np.diff(active.indptr)
    touched = counts > 0
    candidate = (
        eligible[:, None]
        & (touched.sum(axis=1) == 1)[:, None]
        & (counts >= share * np.maximum(n_active, 1)[:, None])
        & touched
    )
    rows, cols = _candidate_entries(active, np.flatnonzero(candidate.any(axis=1)))
    moved = np.take(deltas.reshape(-1, 3), rows * active.shape[1] + cols, axis=0)  # the candidates' only
    summed = np.column_stack(
        [np.bincount(rows, weights=moved[:, d], minlength=active.shape[0]) for d in range(3)]
    )
    direction = summed / np.maximum(np.linalg.norm(summed, axis=1, keepdims=True), np.finfo(float).tiny)

    first_all, second_all, cosine_all = [], [], []
    for upper, lower in region_pairs:  # a handful of sketch pairs
        ks = np.flatnonzero(candidate[:, names.index(upper)])
        ms = np.flatnonzero(candidate[:, names.index(lower)])
        cosine = direction[ks] @ direction[ms].T
        opposite_k, opposite_m = np.nonzero(cosine < cos_threshold)
        first_all.append(ks[opposite_k])
        second_all.append(ms[opposite_m])
        cosine_all.append(cosine[opposite_k, opposite_m])
    return match_pairs(np.concatenate(first_all), np.concatenate(second_all), np.concatenate(cosine_all))


def _candidate_entries(active: sp.csr_matrix, shapes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Row and column index of the active entries of the ascending ``shapes``, in row-major order."""
    counts = active.indptr[shapes + 1] - active.indptr[shapes]
    rows = np.repeat(shapes.astype(np.int64), counts)
    entry = np.repeat(active.indptr[shapes] - np.cumsum(counts) + counts, counts) + np.arange(rows.size)
    return rows, active.indices[entry].astype(np.int64)


def sketch_regions(
    rig: Rig, params: PackingParams
) -> tuple[dict[str, np.ndarray], tuple[tuple[str, str], ...], str]:
    """The regions and region pairs motion symmetry uses (sec. 4.4.2), and a note on any pair skipped.

    The regions are the rig's own, or ``params.regions``: a mapping, or a JSON/OBJ file read by
    `rigs.read_regions`. With the default region pairs, a pair whose regions are missing is skipped and the
    note says so, unless user-given regions hold none of the default pairs (then their names are surely
    not the ones meant). Explicitly chosen region pairs must all exist.

    Raises
    ------
    ValueError
        Naming the missing regions and the regions there are.
    """
    if params.regions is None:
        regions, source = dict(rig.regions), "rig"
    elif isinstance(params.regions, Mapping):
        regions, source = regions_from_mapping(params.regions, rig.n_vertices), "given"
    else:
        regions, source = read_regions(params.regions, rig.n_vertices), str(params.regions)
    pairs = params.region_pairs
    missing = sorted({name for pair in pairs for name in pair} - set(regions))
    if not missing:
        return regions, pairs, ""
    usable = tuple(pair for pair in pairs if pair[0] in regions and pair[1] in regions)
    if pairs == DEFAULT_REGION_PAIRS and (usable or params.regions is None):
        skipped = [f"{a}/{b}" for a, b in pairs if (a, b) not in usable]
        return (
            regions,
            usable,
            f"motion symmetry skipped region pairs {', '.join(skipped)}: {source} has no such regions",
        )
    raise HarnessError(
        f"motion symmetry: no region {', '.join(map(repr, missing))} of the region pairs; "
        f"{source} regions: {', '.join(sorted(regions)) or 'none'}"
    )
