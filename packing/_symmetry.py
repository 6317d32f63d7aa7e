"""Symmetric blendshape pairs: shape symmetry (eqs. 9-10) and motion symmetry (eqs. 11-12), sec. 4.4."""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sp

from packing._binary import displacement_norms, empty_mask, entries, masks_from_norms, sparse_masks
from packing._params import DEFAULT_REGION_PAIRS, PackingParams, params_from
from rigs import Rig, mirror_map


@dataclass(frozen=True)
class SymmetryResult:
    """Detected pairs with their evidence.

    Attributes
    ----------
    shape_pairs : tuple of (int, int)
        Mirror pairs (eqs. 9-10), shape indices, lower index first, in order of increasing error.
    shape_errors : tuple of float
        ``max(eps_km, eps_mk)`` of each shape pair (eq. 9).
    motion_pairs : tuple of (int, int)
        Motion pairs (eqs. 11-12): first shape from the first region of its region pair.
    motion_cosines : tuple of float
        ``cos(phi_km)`` of each motion pair (eq. 12).
    self_symmetric : tuple of int
        Shapes symmetric to themselves, excluded from mirror pairs.
    unmirrored : int
        Vertices without a mirror vertex (reported by the mirror map).
    notes : tuple of str
        What was skipped and why (e.g. a rig without the default sketch regions).
    """

    shape_pairs: tuple[tuple[int, int], ...] = ()
    shape_errors: tuple[float, ...] = ()
    motion_pairs: tuple[tuple[int, int], ...] = ()
    motion_cosines: tuple[float, ...] = ()
    self_symmetric: tuple[int, ...] = ()
    unmirrored: int = 0
    notes: tuple[str, ...] = ()

    @property
    def pairs(self) -> tuple[tuple[int, int], ...]:
        """All pairs, mirror pairs first."""
        return self.shape_pairs + self.motion_pairs


def reflection_normal(neutral: np.ndarray, mirror: np.ndarray) -> np.ndarray | None:
    """Unit normal of the symmetry plane implied by a mirror map (principal direction of the chords).

    None when no vertex is matched to a different vertex.
    """
    source = np.flatnonzero(mirror >= 0)
    chords = neutral[source] - neutral[mirror[source]]
    chords = chords[np.einsum("ij,ij->i", chords, chords) > 0]
    if chords.shape[0] == 0:
        return None
    _, _, directions = np.linalg.svd(chords, full_matrices=False)
    return directions[0]


def shape_symmetry(
    deltas: np.ndarray,
    norms: np.ndarray,
    masks: np.ndarray,
    mirror: np.ndarray,
    normal: np.ndarray,
    eligible: np.ndarray,
    tol: float = 0.4,
) -> tuple[list[tuple[int, int, float]], np.ndarray]:
    """Mirror pairs and self-symmetric shapes (Carrigan et al. 2020, eqs. 9-10).

    With ``P_m^n = R dv_m^{mirror(n)}`` the reflected displacement and ``p(b_m)^n = b_m^{mirror(n)}``
    the mirrored binary mask,

        eps_km = sum_n |b_k^n dv_k^n - p(b_m)^n P_m^n| / sum_n (b_k^n & p(b_m)^n)    (eq. 9)

    (the paper writes ``b_m^n p(dv_m^n)``; the mask has to be mirrored with the displacement). A shape
    is self-symmetric when ``eps_kk`` passes eq. 10; such shapes are excluded. Two shapes are a pair
    when both ``eps_km`` and ``eps_mk`` are below ``tol * min(max_n |dv_k^n|, max_n |dv_m^n|)``
    (eq. 10); the pairs with the lowest error ``max(eps_km, eps_mk)`` are taken first and each shape
    joins at most one pair.

    Parameters
    ----------
    deltas : (K, N, 3) array
    norms : (K, N) array
        Displacement lengths.
    masks : (K, N) bool array or sparse matrix
        Binary blendshapes (eq. 2).
    mirror : (N,) int array
        Mirror vertex of each vertex, -1 for none (`rigs.mirror_map`).
    normal : (3,) array
        Unit normal of the symmetry plane.
    eligible : (K,) bool array
        Shapes that may be paired (non-empty ones).
    tol : float
        Factor of eq. 10 (paper: 0.4).

    Returns
    -------
    pairs : list of (k, m, error)
        Accepted pairs, ``k < m``, by increasing error.
    self_symmetric : (K,) bool array

    Notes
    -----
    Splitting ``|a - p| = |a| + |p| + (|a - p| - |a| - |p|)`` makes the numerator a per-shape sum plus
    a correction over the vertices where both masks are set. Sparse products of the masks with the
    mirrored masks give every denominator and a lower bound of every numerator at once
    (``|a - p| >= ||a| - |p||``); displacement vectors are read only for the few pairs that the bound
    leaves, never for all K^2 N combinations. Pairs whose mirrored masks do not intersect have an
    infinite error.
    """
    active = sparse_masks(masks)
    n_shapes, n_vertices = active.shape
    rows, cols = entries(active)
    keys = rows * n_vertices + cols  # ascending: row-major entries
    valid = mirror >= 0
    largest = norms.max(axis=1)
    # The displacements of the active entries only, compact and in key order: direct and reflected.
    moved = deltas.reshape(-1, 3)[keys]
    reflected = moved @ (np.eye(3) - 2.0 * np.outer(normal, normal))
    moved_lengths = norms.ravel()[keys]

    # Per-shape and per-pair sums by sparse products with the mirrored masks p(b_m).
    ones = active.astype(np.float64)
    lengths = sp.csr_matrix((moved_lengths, active.indices, active.indptr), shape=active.shape)
    keep_valid = sp.diags(valid.astype(np.float64))
    image_of = np.where(valid, mirror, 0)
    mirrored_masks = ones[:, image_of] @ keep_valid  # p(b_m)
    mirrored_lengths = lengths[:, image_of] @ keep_valid  # |p(b_m) P_m| per vertex
    own = np.asarray(lengths.sum(axis=1)).ravel()  # sum_n |b_k dv_k|
    mirrored = np.asarray(mirrored_lengths.sum(axis=1)).ravel()  # sum_n |p(b_m) P_m|
    overlap = (ones @ mirrored_masks.T).toarray()  # |b_k & p(b_m)|, the denominator of eq. 9
    own_shared = (lengths @ mirrored_masks.T).toarray()  # sum over b_k & p(b_m) of |b_k dv_k|
    mirrored_shared = (ones @ mirrored_lengths.T).toarray()  # ... and of |p(b_m) P_m|

    # Self-symmetry: eq. 9 with m = k, over the active (k, n) whose mirror vertex is active in k too.
    found, image_entry = _find(keys, rows * n_vertices + mirror[cols])
    both = np.flatnonzero(valid[cols] & eligible[rows] & found)
    shape = rows[both]
    correction = _correction(moved, reflected, moved_lengths, both, image_entry[both])
    total = own + mirrored + np.bincount(shape, weights=correction, minlength=n_shapes)
    diagonal = np.diag(overlap)
    self_error = np.divide(total, diagonal, out=np.full(n_shapes, np.inf), where=diagonal > 0)
    self_symmetric = eligible & (self_error < tol * largest)

    # Pairs among the rest. |a - p| >= ||a| - |p|| bounds eq. 9 from below by
    # (own_k + mirrored_m - 2 min(own_shared, mirrored_shared)) / overlap, which rules out most pairs
    # before any displacement vector is read.
    threshold = tol * np.minimum(largest[:, None], largest[None, :])
    candidates = eligible & ~self_symmetric
    with np.errstate(divide="ignore", invalid="ignore"):
        bound = (own[:, None] + mirrored[None, :] - 2.0 * np.minimum(own_shared, mirrored_shared)) / overlap
    possible = (overlap > 0) & (bound < threshold) & candidates[:, None] & candidates[None, :]
    possible &= possible.T
    np.fill_diagonal(possible, False)
    first, second = np.nonzero(possible)
    k, m, entry, image_entry = _shared_vertices(active, first, second, mirror, keys)
    pair_id = k * n_shapes + m
    correction = _correction(moved, reflected, moved_lengths, entry, image_entry)
    summed = np.bincount(pair_id, weights=correction, minlength=n_shapes * n_shapes).reshape(
        n_shapes, n_shapes
    )
    error = np.full((n_shapes, n_shapes), np.inf)
    error[first, second] = (own[first] + mirrored[second] + summed[first, second]) / overlap[first, second]
    score = np.maximum(error, error.T)
    first, second = np.nonzero(np.triu(score < threshold, k=1))
    return _match(first, second, score[first, second]), self_symmetric


def _find(sorted_keys: np.ndarray, probes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Whether each probe occurs in an ascending key array, and where (valid where found)."""
    if sorted_keys.size == 0:
        return np.zeros(probes.size, dtype=bool), np.zeros(probes.size, dtype=np.int64)
    position = np.minimum(np.searchsorted(sorted_keys, probes), sorted_keys.size - 1)
    return sorted_keys[position] == probes, position


def _shared_vertices(
    active: sp.csr_matrix, first: np.ndarray, second: np.ndarray, mirror: np.ndarray, keys: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """For the pairs (k, m): every (k, n) with ``b_k^n`` and ``b_m^{mirror(n)}``, vectorised.

    Every active vertex n of k is probed for the active entry (m, mirror(n)) in the sorted entry keys.

    Returns
    -------
    k, m : int arrays
        The pair of each shared vertex.
    entry, image_entry : int arrays
        Positions of the entries (k, n) and (m, mirror(n)) in ``keys``.
    """
    n_vertices = active.shape[1]
    counts = np.diff(active.indptr)[first]
    owner = np.repeat(np.arange(first.size), counts)
    entry = (
        active.indptr[first][owner]
        + np.arange(int(counts.sum()))
        - np.repeat(np.cumsum(counts) - counts, counts)
    )
    image = mirror[active.indices[entry]]
    found, image_entry = _find(keys, second[owner] * n_vertices + image)
    shared = (image >= 0) & found
    return first[owner][shared], second[owner][shared], entry[shared], image_entry[shared]


def _correction(
    moved: np.ndarray, reflected: np.ndarray, lengths: np.ndarray, entry: np.ndarray, image_entry: np.ndarray
) -> np.ndarray:
    """``|dv_k^n - R dv_m^{mirror(n)}| - |dv_k^n| - |dv_m^{mirror(n)}|`` for pairs of active entries."""
    difference = moved[entry] - reflected[image_entry]
    return np.sqrt(np.einsum("ij,ij->i", difference, difference)) - lengths[entry] - lengths[image_entry]


def _match(first: np.ndarray, second: np.ndarray, score: np.ndarray) -> list[tuple[int, int, float]]:
    """Greedy matching by increasing score (ties by indices): each shape joins at most one pair."""
    order = np.lexsort((second, first, score))
    taken: set[int] = set()
    pairs = []
    for index in order:  # loops over candidate pairs (a few per shape), not vertices
        a, b = int(first[index]), int(second[index])
        if a in taken or b in taken:
            continue
        taken.update((a, b))
        pairs.append((a, b, float(score[index])))
    return pairs


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
    rows, cols = entries(active)
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
    moved = deltas[rows, cols]
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
    return _match(np.concatenate(first_all), np.concatenate(second_all), np.concatenate(cosine_all))


def load_regions(source: Mapping[str, Any] | str | Path, n_vertices: int) -> dict[str, np.ndarray]:
    """Vertex regions from a mapping or a JSON file ``{"name": [vertex indices], ...}``.

    Raises
    ------
    ValueError
        Naming the file and region when the file is missing or malformed or an index is out of range.
    """
    origin = "regions"
    if not isinstance(source, Mapping):
        path = Path(source)
        origin = str(path)
        try:
            source = json.loads(path.read_text())
        except FileNotFoundError:
            raise ValueError(f"{path}: regions file not found") from None
        except (OSError, json.JSONDecodeError) as error:
            raise ValueError(f"{path}: cannot read regions JSON: {error}") from None
        if not isinstance(source, Mapping):
            raise ValueError(f"{path}: regions JSON must be an object of name -> vertex list")
    regions = {}
    for name, indices in source.items():
        try:
            array = np.asarray(indices)
            if array.dtype == bool:
                array = np.flatnonzero(array)
            if array.size and not np.issubdtype(array.dtype, np.integer):
                raise TypeError
            array = array.astype(np.int64).ravel()
        except (TypeError, ValueError):
            raise ValueError(f"{origin}: region {name!r} must be a list of vertex indices") from None
        if array.size and (array.min() < 0 or array.max() >= n_vertices):
            raise ValueError(f"{origin}: region {name!r} indexes outside 0..{n_vertices - 1}")
        regions[str(name)] = np.unique(array)
    return regions


def sketch_regions(
    rig: Rig, params: PackingParams
) -> tuple[dict[str, np.ndarray], tuple[tuple[str, str], ...], str]:
    """The regions and region pairs motion symmetry uses, and a note on any default pair skipped.

    Explicitly chosen regions or pairs must all exist; with the defaults on a rig that lacks some of
    the default regions, the missing pairs are skipped and the note says so.
    """
    regions = dict(rig.regions) if params.regions is None else load_regions(params.regions, rig.n_vertices)
    pairs = params.region_pairs
    missing = sorted({name for pair in pairs for name in pair} - set(regions))
    if not missing:
        return regions, pairs, ""
    if params.regions is None and pairs == DEFAULT_REGION_PAIRS:
        usable = tuple(pair for pair in pairs if pair[0] in regions and pair[1] in regions)
        skipped = [f"{a}/{b}" for a, b in pairs if (a, b) not in usable]
        return (
            regions,
            usable,
            f"motion symmetry skipped region pairs {', '.join(skipped)}: rig has no such regions",
        )
    source = (
        str(params.regions)
        if params.regions is not None and not isinstance(params.regions, Mapping)
        else "rig"
    )
    raise ValueError(
        f"unknown region name {', '.join(map(repr, missing))} in region_pairs; "
        f"{source} regions: {', '.join(sorted(regions)) or 'none'}"
    )


def detect_pairs(
    rig: Rig, deltas_norms: np.ndarray, masks: np.ndarray, empty: np.ndarray, params: PackingParams
) -> SymmetryResult:
    """Mirror pairs first, then motion pairs among the shapes left unpaired (sec. 4.4)."""
    eligible = ~empty
    notes: list[str] = []
    shape_pairs: list[tuple[int, int, float]] = []
    self_symmetric = np.zeros(rig.n_shapes, dtype=bool)
    unmirrored = 0
    if params.use_shape_symmetry:
        mirror = mirror_map(rig.neutral, tol=params.mirror_tol)
        unmirrored = int(np.count_nonzero(mirror < 0))
        normal = reflection_normal(rig.neutral, mirror)
        if normal is None:
            notes.append("shape symmetry skipped: no vertex has a mirror vertex")
        else:
            shape_pairs, self_symmetric = shape_symmetry(
                rig.deltas, deltas_norms, masks, mirror, normal, eligible, params.shape_tol
            )
        if unmirrored:
            notes.append(f"{unmirrored} of {rig.n_vertices} vertices have no mirror vertex")
    motion_pairs: list[tuple[int, int, float]] = []
    if params.use_motion_symmetry:
        regions, region_pairs, note = sketch_regions(rig, params)
        if note:
            notes.append(note)
        paired = np.zeros(rig.n_shapes, dtype=bool)
        paired[[k for pair in shape_pairs for k in pair[:2]]] = True
        motion_pairs = motion_symmetry(
            rig.deltas,
            masks,
            regions,
            region_pairs,
            eligible & ~paired,
            params.motion_cos,
            params.motion_share,
        )
    return SymmetryResult(
        shape_pairs=tuple((a, b) for a, b, _ in shape_pairs),
        shape_errors=tuple(error for *_, error in shape_pairs),
        motion_pairs=tuple((a, b) for a, b, _ in motion_pairs),
        motion_cosines=tuple(cosine for *_, cosine in motion_pairs),
        self_symmetric=tuple(int(k) for k in np.flatnonzero(self_symmetric)),
        unmirrored=unmirrored,
        notes=tuple(notes),
    )


def find_symmetry_pairs(
    rig: Rig, *, mu: float = 0.3, shape: bool = True, motion: bool = True, **params: Any
) -> list[tuple[str, str]]:
    """Symmetric blendshape pairs of a rig (Carrigan et al. 2020, sec. 4.4).

    Mirror pairs by shape symmetry (eqs. 9-10, over the vertex mirror map of the neutral), then
    motion pairs (eqs. 11-12, over the sketched region pairs) among the shapes not yet paired.
    Self-symmetric and empty shapes are never paired; each shape is in at most one pair.

    Parameters
    ----------
    rig : Rig
    mu : float in (0, 1]
        Threshold of the binary blendshapes (eq. 2).
    shape, motion : bool
        Switch each kind of symmetry on or off.
    **params
        Further `PackingParams`: ``shape_tol``, ``motion_cos``, ``motion_share``, ``region_pairs``,
        ``regions`` (mapping or JSON file), ``mirror_tol``, ``noise_floor``.

    Returns
    -------
    list of (str, str)
        Mirror pairs by increasing error, then motion pairs by increasing angle.

    Raises
    ------
    ValueError
        For parameters out of range or region names the rig (or regions file) does not have.
    """
    settings = params_from(mu=mu, shape_symmetry=shape, motion_symmetry=motion, **params)
    norms = displacement_norms(rig.deltas)
    empty = empty_mask(norms, settings.noise_floor, rig.diagonal())
    masks = masks_from_norms(norms, settings.mu, empty)
    result = detect_pairs(rig, norms, masks, empty, settings)
    return [(rig.names[a], rig.names[b]) for a, b in result.pairs]
