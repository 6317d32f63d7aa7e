"""Candidate mirror pairs by spatial hashing (Carrigan et al. 2020, eqs. 9-10, sec. 4.4.1): per-cell sums of
the displacements rule out the pairs that cannot pass eq. 10 before any vertex is compared."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from packing._symmetry_field import Preimages, SymmetryField, is_involution, reflect
from rigs import bounding_box

#: Cells of the spatial hash along a typical shape's extent (`vertex_cells`).
CELLS_PER_SHAPE = 4
#: Shapes whose extents set the cell side (`vertex_cells` takes this many to twice as many, evenly spaced).
EXTENT_SAMPLE = 256
#: Largest number of (cell, shape) sums the spatial hash keeps (`vertex_cells` coarsens the grid to stay
#: below, down to one grid cell: its up to four mirror sides may then hold 4 K sums, only for a budget of
#: fewer than four sums per shape).
MAX_CELL_SUMS = 2_000_000
#: (cell, shape, shape) combinations `candidate_pairs` visits at once (bounds its temporary arrays).
COMBO_CHUNK = 1 << 18
#: Relative slack of the bounds in `candidate_pairs`, far above their rounding error: a pair is ruled out
#: only when its bound clears the threshold by this much.
BOUND_SLACK = 1e-9


def vertex_cells(
    neutral: np.ndarray | None,
    active: sp.csr_matrix,
    cols: np.ndarray,
    candidates: np.ndarray,
    mirror: np.ndarray | None = None,
    normal: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray | None]:
    """(N,) cell of each vertex: a grid over the neutral whose side is the median extent of the candidate
    shapes' active vertices over `CELLS_PER_SHAPE`; without a neutral, runs of consecutive vertices.

    The median is taken over an evenly spaced sample of the candidate shapes (all of them below twice
    `EXTENT_SAMPLE`, else every j-th, at least `EXTENT_SAMPLE`): the grid sets only how tight the bounds of
    `candidate_pairs` are, never which pairs pass.

    Returns
    -------
    cell : (N,) int array
    flip : (C,) int array or None
        For an involutive ``mirror``, the cell holding the mirror vertices of each cell's vertices (-1 for
        the cells of vertices without one): the cells are mirror images of each other, ``cell(mirror(n)) =
        flip(cell(n))``. Of each pair of mirror vertices the one farther along ``normal`` (the lower index
        without a neutral or normal, or on a tie) is placed in the grid and the other in the image of its
        cell, so that each cell lies in one half of the face. None for any other map (or no ``mirror``).
    """
    n_shapes, n_vertices = active.shape
    most = max(1, min(n_vertices, MAX_CELL_SUMS // max(n_shapes, 1)))
    vertex = np.arange(n_vertices)
    anchor, side = vertex, None
    if mirror is not None and is_involution(mirror):
        partner = np.where(mirror >= 0, mirror, vertex)
        placed = vertex <= partner
        if neutral is not None and normal is not None:
            height = neutral @ normal
            placed = (height > height[partner]) | ((height == height[partner]) & placed)
        anchor = np.where(placed, vertex, partner)
        side = np.select([mirror < 0, partner == vertex, placed], [_UNMIRRORED, _ON_PLANE, _PLACED], _IMAGE)
    counts = np.diff(active.indptr)
    shapes = np.flatnonzero(candidates & (counts > 0))
    if neutral is None or shapes.size == 0:  # (at most four sides of a run)
        return _with_images(anchor * (most if side is None else max(1, most // 4)) // n_vertices, side)
    shapes = shapes[:: max(1, shapes.size // EXTENT_SAMPLE)]
    cols = np.concatenate([cols[active.indptr[k] : active.indptr[k + 1]] for k in shapes.tolist()])
    first = np.zeros(shapes.size, dtype=np.int64)
    np.cumsum(counts[shapes][:-1], out=first[1:])
    low, high = np.empty((shapes.size, 3)), np.empty((shapes.size, 3))
    for axis in range(3):  # one coordinate of the active entries at a time
        coordinate = np.take(neutral[:, axis], cols)
        low[:, axis] = np.minimum.reduceat(coordinate, first)
        high[:, axis] = np.maximum.reduceat(coordinate, first)
    length = float(np.median(np.linalg.norm(high - low, axis=1))) / CELLS_PER_SHAPE
    origin, top = bounding_box(neutral)
    span = float(np.linalg.norm(top - origin))
    length = max(length, span * 1e-6, np.finfo(float).tiny)
    placed_at = neutral[anchor]
    while True:
        grid = np.floor((placed_at - origin) / length).astype(np.int64)
        width = bounding_box(grid)[1] + 1
        _, cell = np.unique((grid[:, 0] * width[1] + grid[:, 1]) * width[2] + grid[:, 2], return_inverse=True)
        cell, flip = _with_images(cell, side)
        if cell.max() < most or (width == 1).all():  # (one grid cell: its sides are at most four cells)
            return cell, flip
        length *= 1.5


#: Sides of a vertex of an involutive mirror map (`vertex_cells`): placed in the grid, the image of a placed
#: vertex, its own mirror vertex, without a mirror vertex.
_PLACED, _IMAGE, _ON_PLANE, _UNMIRRORED = 0, 1, 2, 3


def _with_images(cell: np.ndarray, side: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None]:
    """The cells of `vertex_cells` from the grid cell of each vertex's placed vertex and its side."""
    if side is None:
        return cell, None
    keys, cell = np.unique(cell.astype(np.int64) * 4 + side, return_inverse=True)
    kind = keys % 4
    flip = np.searchsorted(keys, keys - kind + np.choose(kind, [_IMAGE, _PLACED, _ON_PLANE, _UNMIRRORED]))
    flip[kind == _UNMIRRORED] = -1
    return cell, flip


@dataclass(frozen=True)
class CellSums:
    """Summed vectors and counts of some shapes' entries per (cell, shape) present (`cell_sums`), and
    each shape's total count of entries."""

    sums: np.ndarray
    counts: np.ndarray
    present: np.ndarray
    totals: np.ndarray


@dataclass(frozen=True)
class Candidates:
    """Ordered pairs (k, m), row-major, that may pass eq. 10 in both directions, with bounds on eq. 9.

    Attributes
    ----------
    first, second : (P,) int arrays
        k and m of each pair; (m, k) is a pair whenever (k, m) is.
    numerator : (P,) array
        A lower bound on the numerator of ``eps_km`` (eq. 9), up to the rounding of its sums.
    shared : (P,) array
        An upper bound on its denominator ``|b_k & p(b_m)|`` (a whole number, at least 1).
    """

    first: np.ndarray
    second: np.ndarray
    numerator: np.ndarray
    shared: np.ndarray


def cell_sums(
    field: SymmetryField,
    rows: np.ndarray,
    cols: np.ndarray,
    preimages: Preimages,
    selected: np.ndarray,
    cell: np.ndarray,
    flip: np.ndarray | None = None,
) -> tuple[CellSums, CellSums]:
    """The per-cell sums `candidate_pairs` reads, of the ``selected`` shapes, in one pass over the active
    entries per coordinate.

    Returns
    -------
    shapes : CellSums
        The summed displacements ``A_kc`` and active counts ``a_kc`` per (cell, shape), and ``|b_k|``.
    image : CellSums
        The summed reflected displacements ``P_mc`` and counts ``p_mc`` of the mirrored masks per (cell,
        shape), and ``|p(b_m)|``. The mirrored entry ``(m, n)`` is the active entry ``(m, mirror(n))``,
        so each active entry ``(m, v)`` is summed into the cell of each preimage n of v: with the key of
        its first preimage, then once more for each further one (none for a one-to-one map). No mirrored
        entry is listed. With the mirror cells ``flip`` of an involutive map (`vertex_cells`), ``P_mc = R
        A_m,flip(c)`` and ``p_mc = a_m,flip(c)``: the shapes' sums, reflected, under their mirror cells.

    Notes
    -----
    Each sum is a `numpy.bincount` over keys ``cell * K + shape`` (entries without a preimage fall in one
    cell past the last, dropped), the displacements read from the compact `SymmetryField.displacements`
    (one contiguous coordinate at a time, for both sums); the image's sums are reflected once summed. The
    sums come in ascending key order.
    """
    n_shapes, n_cells = selected.size, int(cell.max()) + 1
    size = (n_cells + 1) * n_shapes
    kind = np.int32 if size < np.iinfo(np.int32).max else np.int64
    shape_key = np.take(cell, cols).astype(kind)
    shape_key *= n_shapes
    shape_key += rows
    shape_counts = np.bincount(shape_key, minlength=n_cells * n_shapes)
    shape_present = _selected_present(shape_counts, selected)
    if flip is None:
        image_cell = np.where(preimages.first >= 0, np.take(cell, preimages.first), n_cells).astype(kind)
        image_key = np.take(image_cell, cols)
        image_key *= n_shapes
        image_key += rows
        extra_key = np.take(cell, preimages.extra_preimage) * n_shapes + np.take(rows, preimages.extra_entry)
        image_counts = np.bincount(image_key, minlength=size)
        if extra_key.size:
            image_counts += np.bincount(extra_key, minlength=size)
        image_present = _selected_present(image_counts[: n_cells * n_shapes], selected)
        image_sums = np.empty((image_present.size, 3))
    shape_sums = np.empty((shape_present.size, 3))
    for axis in range(3):
        column = np.ascontiguousarray(field.displacements[:, axis])
        shape_sums[:, axis] = np.bincount(shape_key, weights=column, minlength=size)[shape_present]
        if flip is None:
            summed = np.bincount(image_key, weights=column, minlength=size)
            if extra_key.size:
                summed += np.bincount(extra_key, weights=column[preimages.extra_entry], minlength=size)
            image_sums[:, axis] = summed[image_present]
    shapes = CellSums(shape_sums, shape_counts[shape_present], shape_present, np.diff(field.active.indptr))
    if flip is not None:
        return shapes, _mirror_cell_sums(shapes, shape_counts, flip, field.reflection)
    n_image = image_counts[: n_cells * n_shapes].reshape(n_cells, n_shapes).sum(axis=0)
    image = CellSums(
        reflect(image_sums, field.reflection, out=image_sums),  # (sum_n R dv = R sum_n dv)
        image_counts[image_present],
        image_present,
        n_image,
    )
    return shapes, image


def _mirror_cell_sums(
    shapes: CellSums, counts: np.ndarray, flip: np.ndarray, reflection: np.ndarray
) -> CellSums:
    """The mirrored masks' sums of an involutive map from the shapes' sums: ``(flip(c), m)`` of each ``(c,
    m)`` whose vertices have mirror vertices, reflected, in ascending key order; ``|p(b_m)|`` from the
    (cell, shape) ``counts`` of every shape."""
    n_shapes = shapes.totals.size
    cells, owners = np.divmod(shapes.present, n_shapes)
    mirrored = np.flatnonzero(flip[cells] >= 0)
    keys = flip[cells[mirrored]] * n_shapes + owners[mirrored]
    order = np.argsort(keys)
    taken = mirrored[order]
    sums = reflect(shapes.sums[taken], reflection)
    n_image = counts.reshape(-1, n_shapes)[flip >= 0].sum(axis=0)
    return CellSums(sums, shapes.counts[taken], keys[order], n_image)


def _selected_present(counts: np.ndarray, selected: np.ndarray) -> np.ndarray:
    """Keys ``cell * K + shape`` with a non-zero count whose shape is ``selected``."""
    present = np.flatnonzero(counts)
    return present[selected[present % selected.size]]


def self_candidates(
    field: SymmetryField,
    rows: np.ndarray,
    shapes: CellSums,
    image: CellSums,
    largest: np.ndarray,
    tol: float,
) -> np.ndarray:
    """(K,) bool: the shapes whose ``eps_kk`` may pass eq. 10 (self-symmetric ones among them), by the
    bounds of `candidate_pairs` for ``m = k``: only their self errors need to be evaluated."""
    n_shapes = largest.size
    common, in_shape, in_image = np.intersect1d(
        shapes.present, image.present, assume_unique=True, return_indices=True
    )
    k = common % n_shapes
    shape_sums, image_sums = shapes.sums[in_shape], image.sums[in_image]
    gap = np.linalg.norm(shape_sums - image_sums, axis=1)
    gap -= np.linalg.norm(shape_sums, axis=1)
    gap -= np.linalg.norm(image_sums, axis=1)
    shared = np.bincount(
        k, weights=np.minimum(shapes.counts[in_shape], image.counts[in_image]), minlength=n_shapes
    )
    gaps = np.bincount(k, weights=gap, minlength=n_shapes)
    every = np.arange(n_shapes)
    keep, _ = _bounds(every, every, shared, gaps, _Totals.of(field, rows, shapes, image), largest, tol)
    return keep & (shared > 0)


@dataclass(frozen=True)
class _Totals:
    """Per shape: ``sum_c |A_kc|``, ``sum_c |P_kc|``, ``|b_k|``, ``|p(b_k)|``, the smallest active length."""

    shape: np.ndarray
    image: np.ndarray
    n_active: np.ndarray
    n_image: np.ndarray
    smallest: np.ndarray

    @classmethod
    def of(cls, field: SymmetryField, rows: np.ndarray, shapes: CellSums, image: CellSums) -> _Totals:
        n_shapes = shapes.totals.size
        shape = np.bincount(shapes.present % n_shapes, np.linalg.norm(shapes.sums, axis=1), n_shapes)
        mirrored = np.bincount(image.present % n_shapes, np.linalg.norm(image.sums, axis=1), n_shapes)
        smallest = np.zeros(n_shapes)
        starts = np.unique(np.searchsorted(rows, np.arange(n_shapes)))
        starts = starts[starts < rows.size]
        smallest[rows[starts]] = np.minimum.reduceat(field.lengths, starts)
        return cls(shape, mirrored, shapes.totals, image.totals, smallest)


def _bounds(
    k: np.ndarray,
    m: np.ndarray,
    count: np.ndarray,
    gaps: np.ndarray,
    totals: _Totals,
    largest: np.ndarray,
    tol: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Whether each pair (k, m) with ``U_km = count`` and summed gaps ``gaps`` may pass eq. 10, and the larger
    of its two numerator bounds (`candidate_pairs`)."""
    numerator = totals.shape[k] + totals.image[m] + gaps
    outside = (totals.n_active[k] - count) * totals.smallest[k] + (
        totals.n_image[m] - count
    ) * totals.smallest[m]
    limit = tol * np.minimum(largest[k], largest[m]) * count * (1.0 + BOUND_SLACK)
    scale = BOUND_SLACK * (totals.shape[k] + totals.image[m] + limit)
    keep = (numerator < limit + scale) & (outside < limit + scale)
    return keep, np.maximum(numerator, outside)


def candidate_pairs(
    field: SymmetryField,
    rows: np.ndarray,
    shapes: CellSums,
    image: CellSums,
    candidates: np.ndarray,
    largest: np.ndarray,
    tol: float,
    flip: np.ndarray | None = None,
) -> Candidates:
    """Ordered pairs (k, m) that may pass eq. 10 in both directions; a superset of those that do.

    With ``x_n = b_k^n dv_k^n - p(b_m)^n P_m^n`` the numerator of eq. 9 is ``sum_n |x_n|``, and for any
    partition of the vertices into cells c it is at least ``sum_c |sum_{n in c} x_n| = sum_c |A_kc - P_mc|``
    (triangle inequality), where ``A_kc`` and ``P_mc`` are the summed displacements of shape k and of the
    mirrored shape m in cell c. Its denominator ``|b_k & p(b_m)|`` is at most ``U_km = sum_c min(a_kc,
    p_mc)`` over the active counts per cell. Every active length of shape k is at least its smallest,
    ``l_k``, which gives a second bound ``((|b_k| - U) l_k + (|p(b_m)| - U) l_m) / U``. A pair is kept when
    both bounds are below the threshold ``tol * min(largest_k, largest_m)`` of eq. 10. Only the (cell, k,
    m) where both shapes are present are visited: ``sum_c |A_kc - P_mc| = sum_c |A_kc| + sum_c |P_mc| +
    sum over those of (|A - P| - |A| - |P|)``.

    Parameters
    ----------
    field : SymmetryField
    rows : (nnz,) int array
        The shape of each active entry.
    shapes, image : CellSums
        The shapes' sums and the mirrored shapes' sums (`cell_sums`), over the same cells, of at least
        the ``candidates``.
    candidates : (K,) bool array
        Shapes that may be paired.
    largest : (K,) array
        ``max_n |dv_k^n|`` of each shape.
    tol : float
        Factor of eq. 10.
    flip : (C,) int array, optional
        The mirror cell of each cell of an involutive map (`vertex_cells`), under which the image's sums
        are the shapes' sums (`cell_sums`).

    Returns
    -------
    Candidates
        The pairs kept, with the larger of the two numerator bounds and ``U_km``.

    Notes
    -----
    Each cell adds the (shapes present) x (mirrored shapes present) block of its terms into two (K, K)
    arrays (a float and an int32 one), about `COMBO_CHUNK` terms at a time: O(K^2 + C) memory and
    O(combinations) time for the C present (cell, shape), with one vectorised step per cell.
    """
    n_shapes = candidates.size
    totals = _Totals.of(field, rows, shapes, image)
    chosen = candidates[shapes.present % n_shapes]
    shape_sums, shape_counts, shape_present = (
        shapes.sums[chosen],
        shapes.counts[chosen],
        shapes.present[chosen],
    )
    chosen = candidates[image.present % n_shapes]
    image_sums, image_counts, image_present = image.sums[chosen], image.counts[chosen], image.present[chosen]
    shape_norms = np.linalg.norm(shape_sums, axis=1)
    image_norms = np.linalg.norm(image_sums, axis=1)
    shape_of, image_of = shape_present % n_shapes, image_present % n_shapes
    shape_counts, image_counts = shape_counts.astype(np.int32), image_counts.astype(np.int32)
    n_cells = int(max(shape_present.max(initial=0), image_present.max(initial=0))) // n_shapes + 1

    # Per cell, the block of every k present with every m whose mirror image is present, added into the
    # (K, K) gap and shared-count bounds, cell after cell (``add.at`` adds term by term, in order). With
    # mirror cells the term of (k, m) in cell c is that of (m, k) in c' = flip(c), as ``|A_kc - R A_mc'| =
    # |A_mc' - R A_kc|``: only the cells c <= flip(c) are visited (of a cell that is its own image, the
    # pairs k < m), and both directions add into the entry (min(k, m), max(k, m)).
    shape_first = np.searchsorted(shape_present, np.arange(n_cells + 1) * n_shapes)
    image_first = np.searchsorted(image_present, np.arange(n_cells + 1) * n_shapes)
    gaps = np.zeros(n_shapes * n_shapes)
    shared = np.zeros(n_shapes * n_shapes, dtype=np.int32)
    shape_columns, image_columns = shape_sums.T.copy(), image_sums.T.copy()
    visited = (np.diff(shape_first) > 0) & (np.diff(image_first) > 0)
    if flip is not None:
        visited &= np.arange(n_cells) <= flip[:n_cells]
    for index in np.flatnonzero(visited).tolist():
        images = slice(image_first[index], image_first[index + 1])
        per_block = max(1, COMBO_CHUNK // (images.stop - images.start))
        for low in range(shape_first[index], shape_first[index + 1], per_block):
            shapes = slice(low, min(low + per_block, shape_first[index + 1]))
            squared = np.subtract.outer(shape_columns[0, shapes], image_columns[0, images])
            squared *= squared  # (the sum of the squares from 0, as 0 + x x = x x)
            for shape_axis, image_axis in zip(shape_columns[1:], image_columns[1:], strict=True):
                difference = np.subtract.outer(shape_axis[shapes], image_axis[images])
                difference *= difference
                squared += difference
            gap = np.sqrt(squared, out=squared)
            gap -= shape_norms[shapes, None]
            gap -= image_norms[None, images]
            count = np.minimum.outer(shape_counts[shapes], image_counts[images]).ravel()
            gap = gap.ravel()
            if flip is None:
                pair = np.add.outer(shape_of[shapes] * n_shapes, image_of[images]).ravel()
            else:
                pair = np.minimum.outer(shape_of[shapes], image_of[images]).ravel() * n_shapes
                pair += np.maximum.outer(shape_of[shapes], image_of[images]).ravel()
                if flip[index] == index:  # (each pair once: k < m)
                    upper = np.flatnonzero(np.less.outer(shape_of[shapes], image_of[images]))
                    pair, gap, count = pair[upper], gap[upper], count[upper]
            np.add.at(gaps, pair, gap)
            np.add.at(shared, pair, count)

    # The bounds of the pairs present in some cell together, a block of shapes k at a time (with mirror
    # cells, of the pairs k < m, in both directions).
    kept, bounds, counts = [], [], []
    gaps, shared = gaps.reshape(n_shapes, n_shapes), shared.reshape(n_shapes, n_shapes)
    per_block = max(1, COMBO_CHUNK // n_shapes)
    for low in range(0, n_shapes, per_block):
        block, columns = slice(low, min(low + per_block, n_shapes)), 0 if flip is None else low
        present = np.flatnonzero(shared[block, columns:])
        k, m = low + present // (n_shapes - columns), columns + present % (n_shapes - columns)
        distinct = np.flatnonzero(k != m)
        k, m, present = k[distinct], m[distinct], present[distinct]
        count = shared[block, columns:].ravel()[present].astype(np.float64)
        gap = gaps[block, columns:].ravel()[present]
        keep, bound = _bounds(k, m, count, gap, totals, largest, tol)
        if flip is not None:
            keep_back, bound_back = _bounds(m, k, count, gap, totals, largest, tol)
            keep &= keep_back
            k, m = np.concatenate([k[keep], m[keep]]), np.concatenate([m[keep], k[keep]])
            bound, count = np.concatenate([bound[keep], bound_back[keep]]), np.concatenate([count[keep]] * 2)
            keep = np.ones(k.size, dtype=bool)
        kept.append(k[keep] * n_shapes + m[keep])
        bounds.append(bound[keep])
        counts.append(count[keep])
    both, bound, count = np.concatenate(kept), np.concatenate(bounds), np.concatenate(counts)
    if flip is None:
        chosen = np.flatnonzero(
            np.isin(both % n_shapes * n_shapes + both // n_shapes, both, assume_unique=True)
        )
    else:
        chosen = np.argsort(both)
    both, bound, count = both[chosen], bound[chosen], count[chosen]
    return Candidates(both // n_shapes, both % n_shapes, bound, count)
