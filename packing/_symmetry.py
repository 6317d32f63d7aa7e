"""Symmetric blendshape pairs: shape symmetry (eqs. 9-10) and motion symmetry (eqs. 11-12), sec. 4.4."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp

from packing._binary import (
    active_lengths,
    entries,
    largest_lengths,
    rig_masks,
    sparse_masks,
)
from packing._constraints import check_consistent, resolve_pairs
from packing._params import DEFAULT_REGION_PAIRS, PackingParams, params_from
from registry import HarnessError
from rigs import Rig, bounding_box, compare_name_pairs, mirror_map, read_regions, regions_from_mapping


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
    overlapping : tuple of (int, int)
        Lowest-error mirror matches refused because their shapes share too many active vertices
        (sec. 4.4.1): shapes spread over both facial halves, never combined.
    artist_pairs : tuple of (int, int)
        The together pairs of the artist constraints, forced together like symmetry pairs.
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
    overlapping: tuple[tuple[int, int], ...] = ()
    artist_pairs: tuple[tuple[int, int], ...] = ()
    unmirrored: int = 0
    notes: tuple[str, ...] = ()

    @property
    def pairs(self) -> tuple[tuple[int, int], ...]:
        """Every pair forced together: mirror pairs, motion pairs, then the artist's together pairs."""
        return self.shape_pairs + self.motion_pairs + self.artist_pairs


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
    the vertices (`_candidate_pairs`): per cell, the summed displacement of each shape and of each mirrored
    shape bound every numerator from below by the triangle inequality, and the active counts bound every
    denominator from above, so the pairs that cannot pass eq. 10 are ruled out from per-cell sums without
    reading a vertex twice. Displacement vectors are then read only for the vertices of the few pairs
    left (`_pair_sums`), never for all K^2 N combinations; the errors of the pairs kept are exactly those
    of eq. 9. Pairs whose mirrored masks do not intersect have an infinite error. O(nnz + C K + P) for
    the nnz active entries, C cells and the P active vertices of the candidate pairs.
    """
    active = sparse_masks(masks)
    n_shapes = active.shape[0]
    rows, cols = entries(active)
    largest = largest_lengths(norms)
    field = _Field.of(deltas, norms, active, rows, cols, normal)
    own = _row_sums(rows, field.lengths, n_shapes)  # sum_n |b_k dv_k|
    mirrored_entries = _mirrored_entries(active, rows, cols, mirror)  # p(b_m)
    mirrored = _row_sums(mirrored_entries[0], field.lengths[mirrored_entries[2]], n_shapes)  # |p(b_m) P_m|
    self_error = _self_errors(field, rows, cols, mirror, eligible, own + mirrored)
    self_symmetric = eligible & (self_error < tol * largest)

    # Pairs among the rest: only those that per-cell bounds cannot rule out are evaluated exactly.
    threshold = tol * np.minimum(largest[:, None], largest[None, :])
    candidates = eligible & ~self_symmetric
    cells = _cells(neutral, active, rows, cols, candidates)
    first, second = _candidate_pairs(field, rows, cols, mirrored_entries, candidates, threshold, cells)
    del mirrored_entries  # (nnz,) arrays no longer needed while the pairs are probed
    overlap, summed = _pair_sums(field, active, cols, mirror, first, second)
    error = np.full((n_shapes, n_shapes), np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        error[first, second] = np.where(
            overlap > 0, (own[first] + mirrored[second] + summed) / overlap, np.inf
        )
    score = np.maximum(error, error.T)
    first, second = np.nonzero(np.triu(score < threshold, k=1))
    matched = _match(first, second, score[first, second])
    if not matched:
        return [], self_symmetric, []
    share = _off_axis_overlap(active, np.array([pair[:2] for pair in matched]), axis_distance)
    kept = share <= max_overlap
    pairs = [pair for pair, keep in zip(matched, kept, strict=True) if keep]
    overlapping = [
        (a, b, float(f)) for (a, b, _), f, keep in zip(matched, share, kept, strict=True) if not keep
    ]
    return pairs, self_symmetric, overlapping


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


@dataclass(frozen=True)
class _Field:
    """The active displacements of a rig as eq. 9 reads them, compact, with where each ``(k, n)`` is.

    Attributes
    ----------
    slot : (K N,) int array
        One more than the position of the active entry ``(k, n)`` among the active entries (row-major),
        at flat index ``k * N + n``; 0 where ``b_k^n`` is not set (so that the array starts as zero pages).
    moved, reflected : (nnz, 3) arrays
        Displacements ``dv_k^n`` of the active entries and their reflections ``R dv_k^n``.
    lengths : (nnz,) array
        Their lengths.
    reflection : (3, 3) array
        ``R``, the reflection through the symmetry plane.
    n_vertices : int
        N.
    """

    slot: np.ndarray
    moved: np.ndarray
    reflected: np.ndarray
    lengths: np.ndarray
    reflection: np.ndarray
    n_vertices: int

    @classmethod
    def of(
        cls,
        deltas: np.ndarray,
        norms: np.ndarray | sp.spmatrix,
        active: sp.csr_matrix,
        rows: np.ndarray,
        cols: np.ndarray,
        normal: np.ndarray,
    ) -> _Field:
        """The field of the active entries ``(rows, cols)`` of ``active``, reflected through the plane of
        unit normal ``normal``."""
        n_shapes, n_vertices = active.shape
        keys = rows * n_vertices + cols
        index_type = np.int32 if keys.size < np.iinfo(np.int32).max else np.int64
        slot = np.zeros(n_shapes * n_vertices, dtype=index_type)
        slot[keys] = np.arange(1, keys.size + 1, dtype=index_type)
        moved = np.take(deltas.reshape(-1, 3), keys, axis=0)
        reflection = np.eye(3) - 2.0 * np.outer(normal, normal)
        lengths = active_lengths(norms, active)
        return cls(slot, moved, moved @ reflection, lengths, reflection, n_vertices)

    def correction(self, entry: np.ndarray, image_entry: np.ndarray) -> np.ndarray:
        """``|dv_k^n - R dv_m^{mirror(n)}| - |dv_k^n| - |dv_m^{mirror(n)}|`` for pairs of active entries
        (positions among the active entries)."""
        difference = np.take(self.moved, entry, axis=0)  # (``take`` gathers rows twice as fast as indexing)
        difference -= np.take(self.reflected, image_entry, axis=0)
        distance = np.einsum("ij,ij->i", difference, difference)
        np.sqrt(distance, out=distance)
        distance -= np.take(self.lengths, entry)
        distance -= np.take(self.lengths, image_entry)
        return distance

    def image_entries(self, shapes: np.ndarray, vertices: np.ndarray, mirror: np.ndarray) -> np.ndarray:
        """Position of the active entry ``(m, mirror(n))`` for each shape m and vertex n; -1 where the
        vertex has no mirror or ``b_m^{mirror(n)}`` is not set."""
        image = np.take(mirror, vertices)
        found = np.take(self.slot, shapes * self.n_vertices + image, mode="clip")
        found[image < 0] = 0  # (those read a wrong slot)
        return found - 1


def _self_errors(
    field: _Field,
    rows: np.ndarray,
    cols: np.ndarray,
    mirror: np.ndarray,
    eligible: np.ndarray,
    outside: np.ndarray,
) -> np.ndarray:
    """(K,) ``eps_kk`` of eq. 9 (infinite where ``b_k & p(b_k)`` is empty), over the active (k, n) whose
    mirror vertex is active in k too; ``outside`` is ``own_k + mirrored_k``. Corrections are summed for the
    ``eligible`` shapes only (the others are never self-symmetric)."""
    n_shapes = outside.size
    image_entry = field.image_entries(rows, cols, mirror)
    found = image_entry >= 0
    diagonal = np.bincount(rows[found], minlength=n_shapes)  # |b_k & p(b_k)|
    both = np.flatnonzero(found & eligible[rows])
    correction = field.correction(both, image_entry[both])
    total = outside + np.bincount(rows[both], weights=correction, minlength=n_shapes)
    return np.divide(total, diagonal, out=np.full(n_shapes, np.inf), where=diagonal > 0)


def _mirrored_entries(
    active: sp.csr_matrix, rows: np.ndarray, cols: np.ndarray, mirror: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The entries ``(m, n)`` of the mirrored masks, ``p(b_m)^n = b_m^{mirror(n)}``.

    Grouped by shape m; within a shape by descending image vertex ``mirror(n)``, then ascending n (a
    fixed order, that of the sparse-product formulation this replaces, so the sums over them and with
    them the errors of eq. 9 are bit for bit those of earlier releases).

    Returns
    -------
    rows, cols : int arrays
        ``m`` and ``n`` of every entry.
    source : int array
        Position of the active entry ``(m, mirror(n))`` among the active entries.
    """
    n_vertices = active.shape[1]
    vertices = np.flatnonzero(mirror >= 0)
    preimages = vertices[np.argsort(mirror[vertices], kind="stable")]  # by image, then ascending
    n_preimages = np.bincount(mirror[vertices], minlength=n_vertices)
    first_preimage = np.cumsum(n_preimages) - n_preimages
    backwards = active.indptr[rows] + active.indptr[rows + 1] - 1 - np.arange(rows.size)  # rows reversed
    images = cols[backwards]
    counts = n_preimages[images]
    offsets = np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)
    source = np.repeat(backwards, counts)
    return rows[source], preimages[np.repeat(first_preimage[images], counts) + offsets], source


def _row_sums(rows: np.ndarray, values: np.ndarray, n_rows: int) -> np.ndarray:
    """(n_rows,) sums of ``values`` grouped by ascending ``rows`` (``np.add.reduceat``, as scipy sums)."""
    sums = np.zeros(n_rows)
    if rows.size:
        starts = np.flatnonzero(np.concatenate([[True], rows[1:] != rows[:-1]]))
        sums[rows[starts]] = np.add.reduceat(values, starts)
    return sums


#: Cells of the spatial hash along a typical shape's extent (`_cells`).
CELLS_PER_SHAPE = 4
#: Largest number of (cell, shape) sums the spatial hash keeps (`_cells` coarsens the grid to stay below).
MAX_CELL_SUMS = 2_000_000


def _cells(
    neutral: np.ndarray | None,
    active: sp.csr_matrix,
    rows: np.ndarray,
    cols: np.ndarray,
    candidates: np.ndarray,
) -> np.ndarray:
    """(N,) cell of each vertex: a grid over the neutral whose side is the median extent of the candidate
    shapes' active vertices over `CELLS_PER_SHAPE`; without a neutral, runs of consecutive vertices."""
    n_shapes, n_vertices = active.shape
    most = max(1, min(n_vertices, MAX_CELL_SUMS // max(n_shapes, 1)))
    counts = np.diff(active.indptr)
    shapes = np.flatnonzero(candidates & (counts > 0))
    if neutral is None or shapes.size == 0:
        return np.arange(n_vertices) * most // n_vertices
    points = np.take(neutral, cols, axis=0)
    low = np.minimum.reduceat(points, active.indptr[shapes], axis=0)
    high = np.maximum.reduceat(points, active.indptr[shapes], axis=0)
    side = float(np.median(np.linalg.norm(high - low, axis=1))) / CELLS_PER_SHAPE
    origin, top = bounding_box(neutral)
    span = float(np.linalg.norm(top - origin))
    side = max(side, span * 1e-6, np.finfo(float).tiny)
    while True:
        grid = np.floor((neutral - origin) / side).astype(np.int64)
        width = bounding_box(grid)[1] + 1
        _, cell = np.unique((grid[:, 0] * width[1] + grid[:, 1]) * width[2] + grid[:, 2], return_inverse=True)
        if cell.max() < most:
            return cell
        side *= 1.5


#: (cell, shape, shape) combinations `_candidate_pairs` visits at once (bounds its temporary arrays).
_COMBO_CHUNK = 1 << 18
#: Relative slack of the bounds in `_candidate_pairs`, far above their rounding error: a pair is ruled out
#: only when its bound clears the threshold by this much.
_BOUND_SLACK = 1e-9


def _candidate_pairs(
    field: _Field,
    rows: np.ndarray,
    cols: np.ndarray,
    mirrored_entries: tuple[np.ndarray, np.ndarray, np.ndarray],
    candidates: np.ndarray,
    threshold: np.ndarray,
    cell: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Ordered pairs (k, m), row-major, that may pass eq. 10 in both directions; a superset of those that do.

    With ``x_n = b_k^n dv_k^n - p(b_m)^n P_m^n`` the numerator of eq. 9 is ``sum_n |x_n|``, and for any
    partition of the vertices into cells c it is at least ``sum_c |sum_{n in c} x_n| = sum_c |A_kc - P_mc|``
    (triangle inequality), where ``A_kc`` and ``P_mc`` are the summed displacements of shape k and of the
    mirrored shape m in cell c. Its denominator ``|b_k & p(b_m)|`` is at most ``U_km = sum_c min(a_kc,
    p_mc)`` over the active counts per cell. Every active length of shape k is at least its smallest,
    ``l_k``, which gives a second bound ``((|b_k| - U) l_k + (|p(b_m)| - U) l_m) / U``. A pair is kept when
    both bounds are below the threshold. Only the (cell, k, m) where both shapes are present are visited:
    ``sum_c |A_kc - P_mc| = sum_c |A_kc| + sum_c |P_mc| + sum over those of (|A - P| - |A| - |P|)``.
    """
    n_shapes = threshold.shape[0]
    n_cells = int(cell.max()) + 1
    mirrored_rows, mirrored_cols, source = mirrored_entries
    shape_sums, shape_counts, shape_present = _cell_sums(
        rows, cell[cols], field.moved, candidates, n_shapes, n_cells
    )
    image_sums, image_counts, image_present = _cell_sums(
        mirrored_rows,
        cell[mirrored_cols],
        np.take(field.moved, source, axis=0),  # (a temporary: freed before the pairs are visited)
        candidates,
        n_shapes,
        n_cells,
    )
    image_sums = image_sums @ field.reflection  # R is linear: the sum of the reflections
    shape_norms = np.linalg.norm(shape_sums, axis=1)
    image_norms = np.linalg.norm(image_sums, axis=1)
    shape_total = np.bincount(shape_present % n_shapes, weights=shape_norms, minlength=n_shapes)
    image_total = np.bincount(image_present % n_shapes, weights=image_norms, minlength=n_shapes)

    # Every (cell, k, m) with k present in the cell and m's mirror image present in it, a run of cells at a
    # time (about `_COMBO_CHUNK` of them), summed into the (K, K) gap and shared-count bounds.
    per_cell_a = np.bincount(shape_present // n_shapes, minlength=n_cells)
    per_cell_p = np.bincount(image_present // n_shapes, minlength=n_cells)
    first_a, first_p = np.cumsum(per_cell_a) - per_cell_a, np.cumsum(per_cell_p) - per_cell_p
    combos = per_cell_a * per_cell_p
    size = n_shapes * n_shapes
    gaps, shared = np.zeros(size), np.zeros(size)
    marks = np.searchsorted(np.cumsum(combos), np.arange(_COMBO_CHUNK, combos.sum(), _COMBO_CHUNK))
    bounds = np.unique(np.concatenate([[0], marks, [n_cells]])).tolist()
    for start, stop in zip(bounds[:-1], bounds[1:], strict=True):
        run = combos[start:stop]
        cell_of = np.repeat(np.arange(start, stop), run)
        local = np.arange(int(run.sum())) - np.repeat(np.cumsum(run) - run, run)
        a = first_a[cell_of] + local // per_cell_p[cell_of]
        p = first_p[cell_of] + local % per_cell_p[cell_of]
        pair = (shape_present[a] % n_shapes) * n_shapes + image_present[p] % n_shapes
        difference = np.take(shape_sums, a, axis=0) - np.take(image_sums, p, axis=0)
        gap = np.sqrt(np.einsum("ij,ij->i", difference, difference)) - shape_norms[a] - image_norms[p]
        gaps += np.bincount(pair, weights=gap, minlength=size)
        shared += np.bincount(pair, weights=np.minimum(shape_counts[a], image_counts[p]), minlength=size)

    # The bounds of the pairs present in some cell together.
    present = np.flatnonzero(shared)
    k, m = present // n_shapes, present % n_shapes
    shared = shared[present]
    numerator = shape_total[k] + image_total[m] + gaps[present]
    smallest = np.zeros(n_shapes)
    starts = np.unique(np.searchsorted(rows, np.arange(n_shapes)))
    starts = starts[starts < rows.size]
    smallest[rows[starts]] = np.minimum.reduceat(field.lengths, starts)
    n_active = np.bincount(rows, minlength=n_shapes)
    n_image = np.bincount(mirrored_rows, minlength=n_shapes)
    outside = (n_active[k] - shared) * smallest[k] + (n_image[m] - shared) * smallest[m]
    limit = threshold[k, m] * shared * (1.0 + _BOUND_SLACK)
    scale = _BOUND_SLACK * (shape_total[k] + image_total[m] + limit)
    keep = np.zeros((n_shapes, n_shapes), dtype=bool)
    keep.flat[present[(numerator < limit + scale) & (outside < limit + scale)]] = True
    keep &= keep.T
    np.fill_diagonal(keep, False)
    return np.nonzero(keep)


def _cell_sums(
    rows: np.ndarray,
    cells: np.ndarray,
    vectors: np.ndarray,
    selected: np.ndarray,
    n_shapes: int,
    n_cells: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Summed vectors and counts of the entries of the ``selected`` shapes per (cell, shape).

    Returns the sums ``(P, 3)``, counts ``(P,)`` and keys ``cell * K + shape`` ``(P,)`` of the P present
    (cell, shape), in ascending key order.
    """
    inside = np.flatnonzero(selected[rows])
    key = np.take(cells, inside) * n_shapes + np.take(rows, inside)
    counts = np.bincount(key, minlength=n_cells * n_shapes)
    present = np.flatnonzero(counts)
    columns = np.take(vectors, inside, axis=0).T.copy()  # x, y and z each contiguous for `bincount`
    sums = np.column_stack(
        [np.bincount(key, weights=column, minlength=counts.size)[present] for column in columns]
    )
    return sums, counts[present], present


#: Active vertices probed at once by `_pair_sums` (bounds its temporary arrays).
_PROBE_CHUNK = 1 << 18


def _pair_sums(
    field: _Field,
    active: sp.csr_matrix,
    cols: np.ndarray,
    mirror: np.ndarray,
    first: np.ndarray,
    second: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """For the pairs (k, m): ``|b_k & p(b_m)|`` and the summed correction over those vertices (eq. 9).

    Every active vertex n of k is probed for ``b_m^{mirror(n)}``, in chunks of about `_PROBE_CHUNK`.
    """
    counts = np.diff(active.indptr)[first]
    overlap = np.zeros(first.size)
    summed = np.zeros(first.size)
    marks = np.searchsorted(np.cumsum(counts), np.arange(_PROBE_CHUNK, counts.sum(), _PROBE_CHUNK))
    bounds = np.unique(np.concatenate([[0], marks, [first.size]])).tolist()
    for start, stop in zip(bounds[:-1], bounds[1:], strict=True):
        block = counts[start:stop]
        owner = np.repeat(np.arange(block.size), block)
        entry = np.repeat(active.indptr[first[start:stop]], block) + (
            np.arange(owner.size) - np.repeat(np.cumsum(block) - block, block)
        )
        image_entry = field.image_entries(np.repeat(second[start:stop], block), cols[entry], mirror)
        shared = image_entry >= 0
        owner, entry, image_entry = owner[shared], entry[shared], image_entry[shared]
        overlap[start:stop] = np.bincount(owner, minlength=block.size)
        summed[start:stop] = np.bincount(
            owner, weights=field.correction(entry, image_entry), minlength=block.size
        )
    return overlap, summed


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
    read = candidate.any(axis=1)[rows]  # displacements are read for the candidates only
    rows, moved = rows[read], deltas[rows[read], cols[read]]
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


def detect_pairs(
    rig: Rig,
    deltas_norms: np.ndarray | sp.spmatrix,
    masks: np.ndarray,
    empty: np.ndarray,
    params: PackingParams,
    together: list[tuple[int, int]] | None = None,
    apart: list[tuple[int, int]] | None = None,
) -> SymmetryResult:
    """Mirror pairs first, then motion pairs among the shapes left unpaired (sec. 4.4), under the artist
    constraints.

    Artist constraints override geometry: a detected pair that is an apart pair is dropped, a shape of a
    together pair joins no detected pair, and the together pairs are kept as `SymmetryResult.artist_pairs`.
    ``together`` and ``apart`` are shape index pairs (default: resolved from ``params``).
    """
    if together is None or apart is None:
        together, apart = resolve_constraints(rig, params, empty)
    names = rig.names
    barred = {frozenset(pair) for pair in apart}
    in_together = np.zeros(rig.n_shapes, dtype=bool)
    in_together[[k for pair in together for k in pair]] = True
    eligible = ~empty & ~in_together
    notes: list[str] = []
    shape_pairs: list[tuple[int, int, float]] = []
    overlapping: list[tuple[int, int, float]] = []
    self_symmetric = np.zeros(rig.n_shapes, dtype=bool)
    unmirrored = 0
    if params.use_shape_symmetry:
        mirror = mirror_map(rig.neutral, tol=params.mirror_tol, triangles=rig.triangles)
        unmirrored = int(np.count_nonzero(mirror < 0))
        normal = reflection_normal(rig.neutral, mirror)
        if normal is None:
            notes.append("shape symmetry skipped: no vertex has a mirror vertex")
        else:
            shape_pairs, self_symmetric, overlapping = shape_symmetry(
                rig.deltas,
                deltas_norms,
                masks,
                mirror,
                normal,
                eligible,
                params.shape_tol,
                params.pair_overlap,
                axis_distances(rig.neutral, mirror, normal),
                rig.neutral,
            )
        if unmirrored:
            notes.append(f"{unmirrored} of {rig.n_vertices} vertices have no mirror vertex")
        if overlapping:
            listed = ", ".join(f"{names[a]}+{names[b]} ({share:.0%})" for a, b, share in overlapping)
            notes.append(
                f"{len(overlapping)} mirror matches overlap on more than {params.pair_overlap:.0%} of their "
                f"active vertices away from the symmetry axis and are not paired (they spread over both "
                f"halves, sec. 4.4.1): {listed}"
            )
        shape_pairs = _drop_barred(shape_pairs, barred, names, notes)
        notes += _name_notes(shape_pairs, overlapping, self_symmetric, names, ~empty & ~in_together)
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
        motion_pairs = _drop_barred(motion_pairs, barred, names, notes)
    return SymmetryResult(
        shape_pairs=tuple((a, b) for a, b, _ in shape_pairs),
        shape_errors=tuple(error for *_, error in shape_pairs),
        motion_pairs=tuple((a, b) for a, b, _ in motion_pairs),
        motion_cosines=tuple(cosine for *_, cosine in motion_pairs),
        self_symmetric=tuple(int(k) for k in np.flatnonzero(self_symmetric)),
        overlapping=tuple((a, b) for a, b, _ in overlapping),
        artist_pairs=tuple(together),
        unmirrored=unmirrored,
        notes=tuple(notes),
    )


def resolve_constraints(
    rig: Rig, params: PackingParams, empty: np.ndarray
) -> tuple[list[tuple[int, int]], list[tuple[int, int]]]:
    """The together and apart pairs of ``params`` as shape indices, checked against the rig.

    Raises
    ------
    ValueError
        For an unknown name (with close matches), a contradiction, or an empty shape in a together pair.
    """
    together = resolve_pairs(rig, params.together, "together")
    apart = resolve_pairs(rig, params.apart, "apart")
    check_consistent(rig, together, apart)
    for pair in together:
        for k in pair:
            if empty[k]:
                raise HarnessError(
                    f"together {','.join(rig.names[j] for j in pair)}: {rig.names[k]} is empty"
                )
    return together, apart


def _name_notes(
    shape_pairs: list[tuple[int, int, float]],
    overlapping: list[tuple[int, int, float]],
    self_symmetric: np.ndarray,
    names: tuple[str, ...],
    considered: np.ndarray,
) -> list[str]:
    """Cross-check of the mirror pairs against left/right names (`rigs.compare_name_pairs`): geometric pairs
    whose names say otherwise, and name twins geometry did not pair (refused as spread, self-symmetric, or
    not found), so that a user sees where the detector and the rig's naming disagree."""
    geometric = [(names[a], names[b]) for a, b, _ in shape_pairs]
    contradicting, missed = compare_name_pairs(geometric, names)
    spread = {frozenset((names[a], names[b])) for a, b, _ in overlapping}
    index = {name: k for k, name in enumerate(names)}
    missed = [
        pair
        for pair in missed
        if frozenset(pair) not in spread and all(considered[index[name]] for name in pair)
    ]
    notes = []
    if contradicting:
        listed = ", ".join(f"{a}+{b}" for a, b in contradicting)
        notes.append(f"mirror pairs whose left/right names are not twins (check them): {listed}")
    if missed:
        listed = ", ".join(
            f"{a}/{b}" + (" (self-symmetric)" if self_symmetric[[index[a], index[b]]].any() else "")
            for a, b in missed
        )
        notes.append(
            f"left/right-named twins that geometry did not pair (eqs. 9-10 found no match): {listed}"
        )
    return notes


def _drop_barred(
    pairs: list[tuple[int, int, float]], barred: set[frozenset[int]], names: tuple[str, ...], notes: list[str]
) -> list[tuple[int, int, float]]:
    """Detected pairs without the artist's apart pairs (each dropped one is noted)."""
    kept = [pair for pair in pairs if frozenset(pair[:2]) not in barred]
    for a, b, _ in (pair for pair in pairs if frozenset(pair[:2]) in barred):
        notes.append(f"{names[a]}+{names[b]} detected as a pair but kept apart by the artist constraints")
    return kept


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
    norms, empty, masks = rig_masks(rig, settings.mu, settings.noise_floor)
    result = detect_pairs(rig, norms, masks, empty, settings)
    return [(rig.names[a], rig.names[b]) for a, b in result.pairs]
