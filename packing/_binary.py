"""Binary blendshapes: which vertices each blendshape moves strongly (Carrigan et al. 2020, sec. 4.1)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

from packing._params import check_range
from rigs import vector_lengths

if TYPE_CHECKING:
    from rigs import Rig


def displacement_norms(deltas: np.ndarray) -> np.ndarray:
    """(K, N) array of ``|dv_k^n|``, the length of every vertex displacement."""
    deltas = np.asarray(deltas, dtype=np.float64)
    if deltas.ndim != 3 or deltas.shape[2] != 3:
        raise ValueError(f"deltas must have shape (K, N, 3), got {deltas.shape}")
    return vector_lengths(deltas)


def empty_mask(norms: np.ndarray, noise_floor: float = 1e-6, scale: float | None = None) -> np.ndarray:
    """(K,) bool array: blendshapes with no displacement above the noise floor.

    Parameters
    ----------
    norms : (K, N) array
        Displacement lengths (`displacement_norms`).
    noise_floor : float
        Relative floor: a shape is empty when its largest displacement is at most
        ``noise_floor * scale``.
    scale : float, optional
        Length scale of the rig, normally its bounding-box diagonal; default the largest displacement
        of any blendshape.
    """
    largest = norms.max(axis=1, initial=0.0)
    if scale is None:
        scale = float(largest.max(initial=0.0))
    return largest <= noise_floor * scale


def empty_shapes(rig: Rig, *, noise_floor: float = 1e-6) -> tuple[str, ...]:
    """Names of a rig's empty blendshapes: no displacement above ``noise_floor`` times its diagonal.

    Empty shapes are excluded from packing (sec. 4.1 would otherwise make every vertex of an all-zero
    shape active, since ``0 >= mu * 0``).
    """
    check_range("noise_floor", noise_floor, 0.0, float("inf"))
    empty = empty_mask(displacement_norms(rig.deltas), noise_floor, rig.diagonal())
    return tuple(rig.names[k] for k in np.flatnonzero(empty))


def binary_blendshapes(
    deltas: np.ndarray, mu: float = 0.3, *, noise_floor: float = 1e-6, scale: float | None = None
) -> np.ndarray:
    """Active-vertex masks of blendshapes (Carrigan et al. 2020, eq. 2).

    A vertex is active in shape k when its displacement is at least ``mu`` times the largest
    displacement of shape k.

    Parameters
    ----------
    deltas : (K, N, 3) array
        Displacements of each blendshape from the neutral.
    mu : float in (0, 1]
        Relative threshold; the paper recommends 0.25-0.4.
    noise_floor : float
        A shape whose largest displacement is at most ``noise_floor * scale`` is empty.
    scale : float, optional
        The rig's length scale (bounding-box diagonal); default the largest displacement of any shape.

    Returns
    -------
    (K, N) bool array. Rows of empty shapes are all False: an empty shape is never "fully active".

    Raises
    ------
    ValueError
        If ``mu`` is outside (0, 1] or ``deltas`` is not (K, N, 3).

    Notes
    -----
    O(K N) time and memory.

    Examples
    --------
    >>> import numpy as np
    >>> deltas = np.array([[[1.0, 0, 0], [0.2, 0, 0], [0.5, 0, 0]], [[0, 0, 0], [0, 0, 0], [0, 0, 0]]])
    >>> binary_blendshapes(deltas, mu=0.3).astype(int).tolist()
    [[1, 0, 1], [0, 0, 0]]
    """
    check_range("mu", mu, 0.0, 1.0, low_open=True)
    norms = displacement_norms(deltas)
    return masks_from_norms(norms, mu, empty_mask(norms, noise_floor, scale))


def sparse_masks(masks: np.ndarray | sp.spmatrix) -> sp.csr_matrix:
    """Binary blendshapes as a (K, N) CSR bool matrix with sorted indices (few vertices are active)."""
    if sp.issparse(masks):
        matrix = sp.csr_matrix(masks, dtype=bool)
        matrix.sort_indices()
        return matrix
    flat = np.flatnonzero(masks)  # row-major, so the columns come grouped by row and ascending
    n_rows, n_cols = masks.shape
    indptr = np.searchsorted(flat, np.arange(n_rows + 1) * n_cols)
    return sp.csr_matrix((np.ones(flat.size, dtype=bool), flat % n_cols, indptr), shape=masks.shape)


def entries(matrix: sp.csr_matrix) -> tuple[np.ndarray, np.ndarray]:
    """Row and column index of every stored entry of a CSR matrix, in row-major order."""
    rows = np.repeat(np.arange(matrix.shape[0]), np.diff(matrix.indptr))
    return rows, matrix.indices.astype(np.int64)


def active_lengths(norms: np.ndarray | sp.spmatrix, active: sp.csr_matrix) -> np.ndarray:
    """``|dv_k^n|`` of the active entries of ``active`` (row-major order).

    ``norms`` is the dense (K, N) array of `displacement_norms`, or a sparse (K, N) matrix holding (at
    least) the lengths of the active entries, as `lengths_matrix` makes it.
    """
    if not sp.issparse(norms):
        rows, cols = entries(active)
        return norms[rows, cols]
    norms = sp.csr_matrix(norms)
    if np.array_equal(norms.indptr, active.indptr) and np.array_equal(norms.indices, active.indices):
        return norms.data
    rows, cols = entries(active)
    return np.asarray(norms[rows, cols]).ravel()


def lengths_matrix(norms: np.ndarray, active: sp.csr_matrix) -> sp.csr_matrix:
    """The lengths of the active entries as a (K, N) CSR matrix with the sparsity of ``active``: all that
    the importance and symmetry terms read of `displacement_norms`, in nnz instead of K N floats."""
    return sp.csr_matrix((active_lengths(norms, active), active.indices, active.indptr), shape=active.shape)


def largest_lengths(norms: np.ndarray | sp.spmatrix) -> np.ndarray:
    """(K,) ``max_n |dv_k^n|`` from dense lengths or `lengths_matrix` (equal for every non-empty shape,
    whose largest displacement is active; 0 for an empty shape in the sparse form)."""
    if sp.issparse(norms):
        return np.asarray(sp.csr_matrix(norms).max(axis=1).todense()).ravel()
    return norms.max(axis=1)


def rig_masks(rig: Rig, mu: float, noise_floor: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Displacement lengths, empty shapes and active-vertex masks of a rig (sec. 4.1, eq. 2).

    A shape is empty when its largest displacement is at most ``noise_floor`` times the rig's bounding-box
    diagonal; its mask row is all False.

    Returns
    -------
    (K, N) float lengths, (K,) bool empty shapes, (K, N) bool masks.
    """
    norms = displacement_norms(rig.deltas)
    empty = empty_mask(norms, noise_floor, rig.diagonal())
    return norms, empty, masks_from_norms(norms, mu, empty)


def masks_from_norms(norms: np.ndarray, mu: float, empty: np.ndarray) -> np.ndarray:
    """Eq. 2 on precomputed displacement lengths; rows of ``empty`` shapes are all False."""
    masks = norms >= mu * norms.max(axis=1, initial=0.0)[:, None]
    masks[empty] = False
    return masks


#: Bytes of displacements whose lengths `active_entries` computes at once (a core's cache holds them and
#: their three products).
LENGTH_BYTES = 1 << 20
#: Lengths `active_entries` holds at once to make their masks (eq. 2 reads each shape's own lengths only).
MASK_LENGTHS = 1 << 19
#: Squares at least ``(1 - SQUARE_SLACK)`` times the square of eq. 2's threshold are rooted and tested: far
#: above the relative rounding of a square root and of a product (about 1e-16 each).
SQUARE_SLACK = 1e-12


def active_entries(
    deltas: np.ndarray, mu: float, noise_floor: float, scale: float, *, gather: bool = False
) -> tuple[sp.csr_matrix, np.ndarray, sp.csr_matrix, np.ndarray | None]:
    """Eq. 2 in one pass over the deltas, a few shapes at a time: `rig_masks` without any (K, N) array.

    The lengths of a block of shapes, their masks and the active entries' lengths (and displacements) are
    made while the block's deltas are still in the cache, so the deltas are read from memory once. Only the
    entries whose squared length is near or above the square of eq. 2's threshold get a square root (a
    fifteenth of them on film-sized rigs; the roots of all of them took a third of the pass).

    Parameters
    ----------
    deltas : (K, N, 3) array
    mu : float in (0, 1]
        Threshold of eq. 2.
    noise_floor, scale : float
        A shape is empty when its largest displacement is at most ``noise_floor * scale`` (`empty_mask`).
    gather : bool
        Also return the displacements ``dv_k^n`` of the active entries.

    Returns
    -------
    lengths : (K, N) CSR matrix
        ``|dv_k^n|`` of the active entries (`lengths_matrix`), bit for bit those of `displacement_norms`.
    empty : (K,) bool array
    active : (K, N) CSR bool matrix with sorted indices (`sparse_masks` of the masks)
    moved : (nnz, 3) array or None
        The active entries' displacements, row-major (with ``gather``).
    """
    n_shapes, n_vertices = deltas.shape[:2]
    step = max(1, LENGTH_BYTES // max(24 * n_vertices, 1))
    per_block = max(step, MASK_LENGTHS // max(n_vertices, 1) // step * step)
    floor = noise_floor * scale
    empty = np.zeros(n_shapes, dtype=bool)
    counts = np.zeros(n_shapes + 1, dtype=np.int64)
    index_type = np.int32 if n_vertices < np.iinfo(np.int32).max else np.int64
    lengths, columns, moved = [np.empty(0)], [np.empty(0, dtype=index_type)], [np.empty((0, 3))]
    buffer, scratch = np.empty(min(per_block, n_shapes) * n_vertices), np.empty(3 * step * n_vertices)
    for start in range(0, n_shapes, per_block):
        block = slice(start, min(start + per_block, n_shapes))
        squares = buffer[: (block.stop - start) * n_vertices].reshape(-1, n_vertices)
        for low in range(start, block.stop, step):
            high = min(low + step, block.stop)
            _squares_into(deltas[low:high], squares[low - start : high - start], scratch)
        largest = np.sqrt(squares.max(axis=1, initial=0.0))  # (the largest length: sqrt is monotonic)
        empty[block] = largest <= floor
        threshold = mu * largest
        threshold[empty[block]] = np.inf
        # Only the squares near or above the threshold's square are rooted; the mask is eq. 2's own test on
        # those lengths (the relative slack covers the roundings of the root and of the square).
        near = np.flatnonzero(squares >= (threshold * threshold * (1.0 - SQUARE_SLACK))[:, None])
        found = np.sqrt(squares.ravel()[near])
        inside = found >= threshold[near // n_vertices]
        flat = near[inside]  # row-major: the order of the active entries
        lengths.append(found[inside])
        columns.append((flat % n_vertices).astype(index_type))
        counts[block.start + 1 : block.stop + 1] = np.bincount(flat // n_vertices, minlength=squares.shape[0])
        if gather:
            moved.append(np.take(np.asarray(deltas[block], dtype=np.float64).reshape(-1, 3), flat, axis=0))
    # Each block list goes as soon as it is joined: the lists and their joins never all coexist (a fifth of
    # the analysis's peak on film-sized rigs).
    del buffer, scratch
    indptr = np.cumsum(counts)
    indices = np.concatenate(columns)
    del columns
    active = sp.csr_matrix((np.ones(indptr[-1], dtype=bool), indices, indptr), shape=(n_shapes, n_vertices))
    matrix = sp.csr_matrix((np.concatenate(lengths), active.indices, active.indptr), shape=active.shape)
    del lengths
    return matrix, empty, active, np.concatenate(moved) if gather else None


def _squares_into(vectors: np.ndarray, squares: np.ndarray, scratch: np.ndarray) -> None:
    """Fill ``squares`` (contiguous) with the squared lengths of (b, N, 3) ``vectors`` (``scratch``: at least
    3 b N floats).

    The squares are summed as ``(x x + z z) + y y``: the order in which `displacement_norms`
    (`rigs.vector_lengths`) sums them on every machine, so that their roots are its lengths bit for bit.
    Squaring the coordinates in one contiguous pass first is faster than three strided products.
    """
    flat = np.ascontiguousarray(vectors, dtype=np.float64).reshape(-1)
    square = scratch[: flat.size]
    np.multiply(flat, flat, out=square)
    summed = squares.reshape(-1)
    np.add(square[0::3], square[2::3], out=summed)
    summed += square[1::3]
