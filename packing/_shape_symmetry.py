"""Shape symmetry: mirror pairs and self-symmetric shapes (Carrigan et al. 2020, eqs. 9-10, sec. 4.4.1)."""

from __future__ import annotations

import heapq
from collections.abc import Callable

import numpy as np
import scipy.sparse as sp

from packing._binary import largest_lengths, sparse_masks
from packing._symmetry_candidates import (
    BOUND_SLACK,
    Candidates,
    candidate_pairs,
    cell_sums,
    self_candidates,
    vertex_cells,
)
from packing._symmetry_field import (
    Preimages,
    SymmetryField,
    compact_entries,
    is_involution,
    mirrored_lengths,
    row_sums,
)


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


def axis_distances(neutral: np.ndarray, mirror: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """(N,) distance of each vertex from the symmetry plane: normal ``normal`` through the median of the
    midpoints between matched vertices and their mirrors."""
    source = np.flatnonzero(mirror >= 0)
    heights = neutral @ normal
    offset = np.median(0.5 * (heights[source] + heights[mirror[source]])) if source.size else 0.0
    return np.abs(heights - offset)


def shape_symmetry(
    deltas: np.ndarray,
    norms: np.ndarray | sp.spmatrix,
    masks: np.ndarray,
    mirror: np.ndarray,
    normal: np.ndarray,
    eligible: np.ndarray,
    tol: float = 0.4,
    max_overlap: float = 0.15,
    axis_distance: np.ndarray | None = None,
    neutral: np.ndarray | None = None,
    moved: np.ndarray | None = None,
) -> tuple[list[tuple[int, int, float]], np.ndarray, list[tuple[int, int, float]]]:
    """Mirror pairs and self-symmetric shapes (Carrigan et al. 2020, eqs. 9-10 and the overlap check).

    With ``P_m^n = R dv_m^{mirror(n)}`` the reflected displacement and ``p(b_m)^n = b_m^{mirror(n)}``
    the mirrored binary mask,

        eps_km = sum_n |b_k^n dv_k^n - p(b_m)^n P_m^n| / sum_n (b_k^n & p(b_m)^n)    (eq. 9)

    (the paper writes ``b_m^n p(dv_m^n)``; the mask has to be mirrored with the displacement). A shape
    is self-symmetric when ``eps_kk`` passes eq. 10; such shapes are excluded. Two shapes are a pair
    when both ``eps_km`` and ``eps_mk`` are below ``tol * min(max_n |dv_k^n|, max_n |dv_m^n|)``
    (eq. 10); the pairs with the lowest error ``max(eps_km, eps_mk)`` are taken first and each shape
    joins at most one pair. Each pair so taken is then checked for overlapping active vertices
    (sec. 4.4.1, "we take the pair with the lowest error and check for possible overlapping ... We allow
    small overlap between symmetric pairs ... at the axis of symmetry"). The overlap that counts is the
    one away from the axis: shared active vertices farther from the symmetry plane than `AXIS_BAND` times
    the farthest active vertex of the pair. A pair whose off-axis overlap exceeds ``max_overlap`` of the
    smaller shape's active vertices spreads over both facial halves (jawLeft/jawRight, mouthLeft/mouthRight:
    mirror images moving the same vertices in opposite directions, whose sum nearly cancels) and is *not*
    combined; both shapes stay unpaired. On generated and Face Units rigs, pairs meeting at the axis have
    an off-axis overlap of at most 0.06 and shapes spread over both halves at least 0.32.

    Parameters
    ----------
    deltas : (K, N, 3) array
    norms : (K, N) array or sparse matrix
        Displacement lengths (at least of the active entries, see `packing._binary.lengths_matrix`).
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
    max_overlap : float in [0, 1]
        Largest share of the smaller shape's active vertices that the two shapes of a pair may share away
        from the symmetry axis.
    axis_distance : (N,) array, optional
        Distance of each vertex from the symmetry plane; without it every shared vertex counts.
    neutral : (N, 3) array, optional
        Vertex positions, for the spatial hash that finds the candidate pairs; without them vertices are
        hashed by index (the result is the same, only the search is slower on meshes whose vertex order
        is not spatially coherent).
    moved : (nnz, 3) array, optional
        The displacements of the active entries, row-major, if already gathered (read, not changed;
        `packing._symmetry_field.SymmetryField.of`).

    Returns
    -------
    pairs : list of (k, m, error)
        Accepted pairs, ``k < m``, by increasing error.
    self_symmetric : (K,) bool array
    overlapping : list of (k, m, share)
        Lowest-error matches refused by the overlap check, with their shared share of active vertices.

    Notes
    -----
    Splitting ``|a - p| = |a| + |p| + (|a - p| - |a| - |p|)`` makes the numerator a per-shape sum plus
    a correction over the vertices where both masks are set. Candidate pairs come from a spatial hash of
    the vertices (`packing._symmetry_candidates.candidate_pairs`): per cell, the summed displacement of
    each shape and of each mirrored shape bound every numerator from below by the triangle inequality, and
    the active counts bound every denominator from above, so the pairs that cannot pass eq. 10 are ruled
    out from per-cell sums without reading a vertex twice. Displacement vectors are then read only for the
    vertices of the few pairs left (`_pair_sums`), never for all K^2 N combinations; the errors of the
    pairs kept are exactly those of eq. 9. Pairs whose mirrored masks do not intersect have an infinite
    error. No (K, N) array is made: O(nnz + C K + P) time and O(nnz + K^2 + `TABLE_CELLS`) memory for the
    nnz active entries, C cells and the P active vertices of the candidate pairs (`TABLE_CELLS` of
    `packing._symmetry_field`).

    A symmetric mesh's mirror map is an involution (``mirror(mirror(n)) = n``), and eq. 9 is then the same
    sum read from either shape of a pair: n is in ``b_k & p(b_m)`` exactly when ``mirror(n)`` is in ``b_m &
    p(b_k)``, with the same term. The search uses it three times: the cells are mirror images of each other
    (the image's per-cell sums are the shapes', and the bounds visit half the cells), a pair is probed from
    its smaller shape only, and a self error from the vertices ``n <= mirror(n)``. Any other map (a noisy
    capture matched to shared or one-way mirror vertices) takes the general path.
    """
    active = sparse_masks(masks)
    n_shapes = active.shape[0]
    rows, cols = compact_entries(active)
    largest = largest_lengths(norms)
    field = SymmetryField.of(deltas, norms, active, rows, cols, normal, moved)
    own = row_sums(rows, field.lengths, n_shapes)  # sum_n |b_k dv_k|
    preimages = Preimages.of(mirror, cols)  # p(b_m)^n = b_m^{mirror(n)}
    image_own = mirrored_lengths(rows, cols, field.lengths, preimages, n_shapes)  # |p(b_m) P_m|

    # Only the shapes and pairs that per-cell bounds cannot rule out are evaluated exactly.
    cells, flip = vertex_cells(neutral, active, cols, eligible, mirror, normal)
    shapes, image = cell_sums(field, rows, cols, preimages, eligible, cells, flip)
    probed = np.flatnonzero(eligible & self_candidates(field, rows, shapes, image, largest, tol))
    self_error = _self_errors(field, rows, cols, mirror, probed, own + image_own)
    self_symmetric = eligible & (self_error < tol * largest)
    candidates = eligible & ~self_symmetric
    found = candidate_pairs(field, rows, shapes, image, candidates, largest, tol, flip)
    matched = _match_by_bounds(field, cols, mirror, own, image_own, found, tol * largest)
    if not matched:
        return [], self_symmetric, []
    share = _off_axis_overlap(active, np.array([pair[:2] for pair in matched]), axis_distance)
    kept = share <= max_overlap
    pairs = [pair for pair, keep in zip(matched, kept, strict=True) if keep]
    overlapping = [
        (a, b, float(f)) for (a, b, _), f, keep in zip(matched, share, kept, strict=True) if not keep
    ]
    return pairs, self_symmetric, overlapping


#: Candidate pairs whose errors `_match_by_bounds` evaluates at once.
EVALUATION_BATCH = 256


def _match_by_bounds(
    field: SymmetryField,
    cols: np.ndarray,
    mirror: np.ndarray,
    own: np.ndarray,
    image_own: np.ndarray,
    found: Candidates,
    threshold: np.ndarray,
) -> list[tuple[int, int, float]]:
    """`match_pairs` over the candidate pairs that pass eq. 10, the errors of eq. 9 evaluated only where the
    matching needs them.

    ``own`` and ``image_own`` are ``sum_n |b_k dv_k|`` and ``sum_n |p(b_m) P_m|`` of each shape, ``threshold``
    is ``tol * max_n |dv_k^n|``. Each unordered pair k < m gets a floor of its score ``max(eps_km,
    eps_mk)`` from the candidate bounds: ``(numerator - s) / shared`` in each direction, with ``s`` =
    `BOUND_SLACK` ``(own_k + image_own_m)`` far above the rounding of either side, and `match_lazily`
    scores the pairs in order of their floors. The matching, and each matched pair's score, are those of
    `match_pairs` over every candidate; on generated film rigs about a sixth of the candidates are scored.
    """
    key = found.first * own.size + found.second
    transposed = np.searchsorted(key, found.second * own.size + found.first)
    slack = BOUND_SLACK * (own[found.first] + image_own[found.second])
    floor = (found.numerator - slack) / found.shared
    upper = np.flatnonzero(found.first < found.second)
    first, second = found.first[upper], found.second[upper]
    floor = np.maximum(floor[upper], floor[transposed[upper]])
    limit = np.minimum(threshold[first], threshold[second])

    def scores_of(pairs: np.ndarray) -> np.ndarray:
        return _scores(field, cols, mirror, own, image_own, first[pairs], second[pairs])

    return match_lazily(first, second, floor, limit, scores_of, own.size)


def match_lazily(
    first: np.ndarray,
    second: np.ndarray,
    floor: np.ndarray,
    limit: np.ndarray,
    scores_of: Callable[[np.ndarray], np.ndarray],
    n_shapes: int,
) -> list[tuple[int, int, float]]:
    """`match_pairs` over the pairs whose score is below their ``limit``, scoring only the pairs it needs.

    ``floor`` is at most each pair's score, ``scores_of(pairs)`` the scores of some pairs (positions). The
    pairs are scored by increasing floor, `EVALUATION_BATCH` at a time, skipping those with a shape already
    matched; a scored pair is matched once its score is below the floor of every pair not yet scored, so no
    such pair can come before it in the order of `match_pairs` (by score, then indices).
    """
    order = np.lexsort((second, first, floor)).tolist()
    firsts, seconds, floors, limits = first.tolist(), second.tolist(), floor.tolist(), limit.tolist()
    taken = bytearray(n_shapes)  # (a byte per shape: read faster than a NumPy array)
    evaluated: list[tuple[float, int, int]] = []  # a heap of (score, k, m) below the limit
    matched: list[tuple[int, int, float]] = []
    position = 0
    while True:  # loops over candidate pairs (a few per shape), not vertices
        while position < len(order) and (taken[firsts[order[position]]] or taken[seconds[order[position]]]):
            position += 1
        while evaluated and (taken[evaluated[0][1]] or taken[evaluated[0][2]]):
            heapq.heappop(evaluated)
        lowest = floors[order[position]] if position < len(order) else np.inf
        if evaluated and evaluated[0][0] < lowest:
            score, a, b = heapq.heappop(evaluated)
            taken[a] = taken[b] = 1
            matched.append((a, b, score))
            continue
        if position == len(order):
            return matched
        batch = []
        while position < len(order) and len(batch) < EVALUATION_BATCH:
            pair = order[position]
            if not (taken[firsts[pair]] or taken[seconds[pair]]):
                batch.append(pair)
            position += 1
        pairs = np.array(batch)
        for pair, score in zip(batch, scores_of(pairs).tolist(), strict=True):
            if score < limits[pair]:
                heapq.heappush(evaluated, (score, firsts[pair], seconds[pair]))


def _scores(
    field: SymmetryField,
    cols: np.ndarray,
    mirror: np.ndarray,
    own: np.ndarray,
    image_own: np.ndarray,
    first: np.ndarray,
    second: np.ndarray,
) -> np.ndarray:
    """``max(eps_km, eps_mk)`` of eq. 9 for the pairs (k, m) (infinite where a mirrored mask misses).

    When the mirror map is an involution (``mirror(mirror(n)) = n`` for every mirrored n, as on a
    symmetric mesh) the two directions share their vertices and their corrections: ``n`` is in
    ``b_k & p(b_m)`` exactly when ``mirror(n)`` is in ``b_m & p(b_k)``, and ``|dv_m - R dv_k| = |R (R dv_m -
    dv_k)| = |dv_k - R dv_m|``. Only the smaller shape of each pair is then probed, and ``eps_km``,
    ``eps_mk`` differ only in ``own_k + image_own_m`` against ``own_m + image_own_k``. Any other map
    probes both directions.
    """
    if not is_involution(mirror):
        k, m = np.concatenate([first, second]), np.concatenate([second, first])
        overlap, summed = _pair_sums(field, cols, mirror, k, m)
        with np.errstate(divide="ignore", invalid="ignore"):
            error = np.where(overlap > 0, (own[k] + image_own[m] + summed) / overlap, np.inf)
        return np.maximum(error[: first.size], error[first.size :])
    n_active = np.diff(field.active.indptr)
    swap = n_active[second] < n_active[first]
    overlap, summed = _pair_sums(
        field, cols, mirror, np.where(swap, second, first), np.where(swap, first, second)
    )
    outside = np.maximum(own[first] + image_own[second], own[second] + image_own[first])
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(overlap > 0, (outside + summed) / overlap, np.inf)


#: Shared active vertices closer to the symmetry plane than this share of a pair's farthest active vertex
#: are the overlap "at the axis of symmetry" that sec. 4.4.1 allows.
AXIS_BAND = 0.25


def _off_axis_overlap(
    active: sp.csr_matrix, pairs: np.ndarray, axis_distance: np.ndarray | None
) -> np.ndarray:
    """Per pair (k, m): shared active vertices outside the axis band, over the smaller shape's active count.

    O(sum of the pairs' active vertices): one sparse row product per pair.
    """
    k, m = pairs[:, 0], pairs[:, 1]
    shared = active[k].multiply(active[m]).tocsr()
    if axis_distance is not None:
        union = (active[k] + active[m]).tocsr()
        reach = sp.csr_matrix((axis_distance[union.indices], union.indices, union.indptr), shape=union.shape)
        band = AXIS_BAND * reach.max(axis=1).toarray().ravel()
        rows = np.repeat(np.arange(shared.shape[0]), np.diff(shared.indptr))
        off_axis = axis_distance[shared.indices] > band[rows]
        counts = np.bincount(rows[off_axis], minlength=shared.shape[0])
    else:
        counts = np.diff(shared.indptr)
    n_active = np.diff(active.indptr)
    return counts / np.maximum(np.minimum(n_active[k], n_active[m]), 1)


def _self_errors(
    field: SymmetryField,
    rows: np.ndarray,
    cols: np.ndarray,
    mirror: np.ndarray,
    shapes: np.ndarray,
    outside: np.ndarray,
) -> np.ndarray:
    """(K,) ``eps_kk`` of eq. 9 of the ascending ``shapes`` (infinite where ``b_k & p(b_k)`` is empty, and
    for the other shapes), over the active (k, n) whose mirror vertex is active in k too; ``outside`` is
    ``own_k + mirrored_k``. The entries are probed a run of whole shapes at a time (about `PROBE_CHUNK`
    entries), so each shape's sum is that of one run, over its entries in ascending order.

    When the mirror map is an involution, n and ``mirror(n)`` contribute the same correction (see
    `_scores`): only the vertices ``n <= mirror(n)`` are probed, the others counted twice."""
    n_shapes = outside.size
    indptr = field.active.indptr
    involutive = is_involution(mirror)
    diagonal = np.zeros(n_shapes)  # |b_k & p(b_k)|
    corrections = np.zeros(n_shapes)
    counts = indptr[shapes + 1] - indptr[shapes]
    ends = np.cumsum(counts)
    marks = np.searchsorted(ends, np.arange(PROBE_CHUNK, int(counts.sum()), PROBE_CHUNK))
    bounds = np.unique(np.concatenate([[0], marks, [shapes.size]])).tolist()
    for low, high in zip(bounds[:-1], bounds[1:], strict=True):
        run = counts[low:high]
        entry = np.repeat(indptr[shapes[low:high]] - np.cumsum(run) + run, run) + np.arange(int(run.sum()))
        vertex = cols[entry]
        weight = None
        if involutive:
            image = np.take(mirror, vertex)
            lower = np.flatnonzero(vertex <= image)
            entry, vertex = entry[lower], vertex[lower]
            weight = np.where(vertex == image[lower], 1.0, 2.0)
        run_rows = rows[entry]
        image_entry = field.image_entries(run_rows, vertex, mirror)
        both = np.flatnonzero(image_entry >= 0)
        correction = field.correction(entry[both], image_entry[both])
        if weight is not None:
            weight = weight[both]
            correction *= weight
        diagonal += np.bincount(run_rows[both], weights=weight, minlength=n_shapes)
        corrections += np.bincount(run_rows[both], weights=correction, minlength=n_shapes)
    total = outside + corrections
    return np.divide(total, diagonal, out=np.full(n_shapes, np.inf), where=diagonal > 0)


#: Active vertices probed at once by `_pair_sums` (bounds its temporary arrays).
PROBE_CHUNK = 1 << 18


def _pair_sums(
    field: SymmetryField,
    cols: np.ndarray,
    mirror: np.ndarray,
    first: np.ndarray,
    second: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """For the pairs (k, m): ``|b_k & p(b_m)|`` and the summed correction over those vertices (eq. 9).

    Every active vertex n of k is probed for ``b_m^{mirror(n)}``, in chunks of about `PROBE_CHUNK`, the
    pairs taken by m (`SymmetryField.image_entries` reads the entries of one run of shapes at a time).
    Each pair's sum runs over its vertices in ascending order, however the pairs are chunked.
    """
    indptr = field.active.indptr
    by_image = np.lexsort((first, second))
    first, second = first[by_image], second[by_image]
    counts = indptr[first + 1] - indptr[first]
    overlap = np.zeros(first.size)
    summed = np.zeros(first.size)
    marks = np.searchsorted(np.cumsum(counts), np.arange(PROBE_CHUNK, counts.sum(), PROBE_CHUNK))
    bounds = np.unique(np.concatenate([[0], marks, [first.size]])).tolist()
    for start, stop in zip(bounds[:-1], bounds[1:], strict=True):
        block = counts[start:stop]
        owner = np.repeat(np.arange(block.size), block)
        entry = np.repeat(indptr[first[start:stop]] - np.cumsum(block) + block, block)
        entry += np.arange(owner.size)
        image_entry = field.image_entries(np.repeat(second[start:stop], block), cols[entry], mirror)
        shared = image_entry >= 0
        owner, entry, image_entry = owner[shared], entry[shared], image_entry[shared]
        overlap[start:stop] = np.bincount(owner, minlength=block.size)
        summed[start:stop] = np.bincount(
            owner, weights=field.correction(entry, image_entry), minlength=block.size
        )
    original = np.empty_like(by_image)
    original[by_image] = np.arange(by_image.size)
    return overlap[original], summed[original]


def match_pairs(first: np.ndarray, second: np.ndarray, score: np.ndarray) -> list[tuple[int, int, float]]:
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
