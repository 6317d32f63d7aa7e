"""The active displacements of a rig as eq. 9 reads them (Carrigan et al. 2020, sec. 4.4.1), and where each
active entry ``(k, n)`` is among them, without a K x N table."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from packing._binary import active_lengths
from rigs import vector_lengths

#: Cells of the (shapes, N) lookup table `SymmetryField.image_entries` fills at once (bounds its memory).
TABLE_CELLS = 1 << 21
#: Vectors `reflect` multiplies by the reflection in one matrix product.
REFLECT_ROWS = 1 << 13


@dataclass(frozen=True)
class SymmetryField:
    """The active displacements, compact, with the sparsity of the binary blendshapes (eq. 2).

    Attributes
    ----------
    active : (K, N) CSR bool matrix with sorted indices
        The binary blendshapes; the active entries are numbered in its (row-major) storage order.
    rows : (nnz,) int array
        The shape of each active entry (its vertex is ``active.indices``).
    displacements : (nnz, 3) array
        The displacements ``dv_k^n`` of the active entries, in their order.
    lengths : (nnz,) array
        Their lengths.
    reflection : (3, 3) array
        ``R``, the reflection through the symmetry plane.
    table : (S N,) int array
        All zero between calls of `image_entries`, which fills it for S shapes at a time (S N at most
        `TABLE_CELLS`); made once, so its pages are touched once.
    """

    active: sp.csr_matrix
    rows: np.ndarray
    displacements: np.ndarray
    lengths: np.ndarray
    reflection: np.ndarray
    table: np.ndarray

    @classmethod
    def of(
        cls,
        deltas: np.ndarray,
        norms: np.ndarray | sp.spmatrix,
        active: sp.csr_matrix,
        rows: np.ndarray,
        cols: np.ndarray,
        normal: np.ndarray,
        moved: np.ndarray | None = None,
    ) -> SymmetryField:
        """The field of the active entries ``(rows, cols)`` of ``active``, with the reflection through the
        plane of unit normal ``normal``. The displacements are gathered once from ``deltas``, unless given as
        ``moved``: the (nnz, 3) float64 displacements of the active entries in their order, kept as they are
        (not copied).

        Raises
        ------
        ValueError
            For a ``moved`` of another shape or type.
        """
        n_vertices = active.shape[1]
        if moved is None:
            position = rows.astype(np.int64) * n_vertices + cols
            moved = np.take(deltas.reshape(-1, 3), position, axis=0)  # (``take``: twice as fast)
        elif moved.shape != (rows.size, 3) or moved.dtype != np.float64:
            raise ValueError(
                f"moved must be the ({rows.size}, 3) float64 displacements of the active entries; got a "
                f"{moved.dtype} array of shape {moved.shape}"
            )
        reflection = np.eye(3) - 2.0 * np.outer(normal, normal)
        lengths = active_lengths(norms, active)
        n_table = min(max(1, TABLE_CELLS // max(n_vertices, 1)), active.shape[0]) * n_vertices
        table = np.zeros(n_table, dtype=index_type(active))
        return cls(active, rows, moved, lengths, reflection, table)

    def moved(self, entry: np.ndarray) -> np.ndarray:
        """(n, 3) displacements ``dv_k^n`` of the active entries ``entry`` (positions)."""
        return np.take(self.displacements, entry, axis=0)

    def correction(self, entry: np.ndarray, image_entry: np.ndarray) -> np.ndarray:
        """``|dv_k^n - R dv_m^{mirror(n)}| - |dv_k^n| - |dv_m^{mirror(n)}|`` for pairs of active entries
        (positions among the active entries), eq. 9's term for one vertex."""
        image = self.moved(image_entry)
        difference = self.moved(entry)
        difference -= reflect(image, self.reflection, out=image)
        distance = vector_lengths(difference)  # (squares summed in one order on every machine)
        distance -= np.take(self.lengths, entry)
        distance -= np.take(self.lengths, image_entry)
        return distance

    def image_entries(self, shapes: np.ndarray, vertices: np.ndarray, mirror: np.ndarray) -> np.ndarray:
        """Position of the active entry ``(m, mirror(n))`` for each shape m and vertex n; -1 where the
        vertex has no mirror or ``b_m^{mirror(n)}`` is not set.

        ``shapes`` must be non-decreasing. The entries of a run of shapes are written into `table`, read
        for the queries of those shapes, and erased again, so the work is O(queries + active entries of
        the queried shapes) and the memory O(`TABLE_CELLS`).
        """
        indptr, indices = self.active.indptr, self.active.indices
        n_vertices = self.active.shape[1]
        image = np.take(mirror, vertices)
        found = np.full(shapes.size, -1, dtype=np.int64)
        if shapes.size == 0:
            return found
        runs = np.flatnonzero(np.concatenate([[True], shapes[1:] != shapes[:-1], [True]]))  # (non-decreasing)
        queried = shapes[runs[:-1]]
        table = self.table
        per_table = table.size // n_vertices
        for start in range(0, queried.size, per_table):
            block = queried[start : start + per_table]
            counts = indptr[block + 1] - indptr[block]
            entry = np.repeat(indptr[block] - np.cumsum(counts) + counts, counts) + np.arange(counts.sum())
            written = np.repeat(np.arange(block.size) * n_vertices, counts) + indices[entry]
            table[written] = entry + 1
            low, high = runs[start], runs[start + block.size]
            local = np.repeat(
                np.arange(block.size) * n_vertices, np.diff(runs[start : start + block.size + 1])
            )
            images = image[low:high]
            hit = np.take(table, local + images, mode="clip") - 1
            hit[images < 0] = -1  # (those read a wrong cell)
            found[low:high] = hit
            table[written] = 0
        return found


def reflect(vectors: np.ndarray, reflection: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """``vectors @ reflection`` for (n, 3) vectors, `REFLECT_ROWS` rows per matrix product (into ``out``,
    which may be ``vectors`` itself: each run is read before it is written).

    One BLAS product over millions of three-column rows is slow (tens of times slower on a busy machine,
    where its threads wait for each other); runs of a few thousand rows are not. Each row of a product is
    computed on its own, so the result is that of one product to the rounding of a three-term sum (bit for
    bit where the BLAS kernels treat every row alike; a remainder of a single row, which numpy would hand to
    a vector routine instead, joins the run before it).
    """
    reflected = out
    if reflected is None:
        reflected = np.empty(
            (vectors.shape[0], reflection.shape[1]), dtype=np.result_type(vectors, reflection)
        )
    bounds = [*range(0, vectors.shape[0], REFLECT_ROWS), vectors.shape[0]]
    if len(bounds) > 2 and bounds[-1] - bounds[-2] == 1:
        del bounds[-2]
    for start, stop in zip(bounds[:-1], bounds[1:], strict=True):
        np.matmul(vectors[start:stop], reflection, out=reflected[start:stop])
    return reflected


def index_type(active: sp.csr_matrix) -> type[np.signedinteger]:
    """The smallest integer type (int32 or int64) that holds every shape, vertex and entry index."""
    largest = max(active.shape[0], active.shape[1], active.indices.size)
    return np.int32 if largest < np.iinfo(np.int32).max else np.int64


def compact_entries(active: sp.csr_matrix) -> tuple[np.ndarray, np.ndarray]:
    """Row and column index of every active entry, row-major, in `index_type` (the columns are the
    matrix's own index array when it has that type)."""
    kind = index_type(active)
    rows = np.repeat(np.arange(active.shape[0], dtype=kind), np.diff(active.indptr))
    return rows, active.indices.astype(kind, copy=False)


@dataclass(frozen=True)
class Preimages:
    """The vertices n that a mirror map sends to each vertex v (``mirror(n) = v``): the mirrored masks
    ``p(b_m)^n = b_m^{mirror(n)}`` of eq. 9 hold the active entry ``(m, v)`` once per preimage of v.

    Attributes
    ----------
    counts : (N,) int array
        Number of preimages of each vertex (1 for every mirrored vertex of a one-to-one map).
    first : (N,) int array
        The smallest preimage of each vertex, -1 for none.
    extra_entry, extra_preimage : int arrays
        Every further (active entry ``(m, v)``, preimage n of v) beyond the first preimage, entry-major:
        empty for a one-to-one map, a few for maps that send neighbouring vertices of a noisy capture to
        the same vertex.
    """

    counts: np.ndarray
    first: np.ndarray
    extra_entry: np.ndarray
    extra_preimage: np.ndarray

    @classmethod
    def of(cls, mirror: np.ndarray, cols: np.ndarray) -> Preimages:
        """The preimages of ``mirror`` (-1 for a vertex without a mirror), with the further ones of the
        active entries at vertices ``cols``."""
        n_vertices = mirror.size
        vertices = np.flatnonzero(mirror >= 0)
        by_image = vertices[np.argsort(mirror[vertices], kind="stable")]  # by image, then ascending
        counts = np.bincount(mirror[vertices], minlength=n_vertices)
        starts = np.cumsum(counts) - counts
        first = np.full(n_vertices, -1, dtype=np.int64)
        mirrored = counts > 0
        first[mirrored] = by_image[starts[mirrored]]
        if counts.max(initial=0) <= 1:
            return cls(counts, first, np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64))
        shared = np.flatnonzero(np.take(counts, cols) > 1)
        repeats = counts[cols[shared]] - 1
        extra_entry = np.repeat(shared, repeats)
        offsets = np.arange(extra_entry.size) - np.repeat(np.cumsum(repeats) - repeats, repeats) + 1
        extra_preimage = by_image[np.repeat(starts[cols[shared]], repeats) + offsets]
        return cls(counts, first, extra_entry, extra_preimage)


def mirrored_lengths(
    rows: np.ndarray, cols: np.ndarray, lengths: np.ndarray, preimages: Preimages, n_shapes: int
) -> np.ndarray:
    """(K,) ``sum_n |p(b_m)^n P_m^n|`` of each shape m: the length of each active entry ``(m, v)`` once
    per preimage of v (``|R x| = |x|``)."""
    return row_sums(rows, lengths * np.take(preimages.counts, cols), n_shapes)


def is_involution(mirror: np.ndarray) -> bool:
    """Whether ``mirror(mirror(n)) = n`` for every vertex n with a mirror vertex (-1 for none)."""
    mirrored = np.flatnonzero(mirror >= 0)
    return bool(np.array_equal(mirror[mirror[mirrored]], mirrored))


def row_sums(rows: np.ndarray, values: np.ndarray, n_rows: int) -> np.ndarray:
    """(n_rows,) sums of ``values`` grouped by ``rows`` (each row's values consecutive; ``np.add.reduceat``,
    as scipy sums)."""
    sums = np.zeros(n_rows)
    if rows.size:
        starts = np.flatnonzero(np.concatenate([[True], rows[1:] != rows[:-1]]))
        sums[rows[starts]] = np.add.reduceat(values, starts)
    return sums
