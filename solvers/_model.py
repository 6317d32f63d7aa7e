"""The presolved model every exact backend builds: one at-most-one row per conflict set, one cap row.

Eq. 3b has one row per vertex; `packing` presolves them to the distinct maximal conflict sets
(``problem.cliques``), which have the same feasible set. Symmetry pairs (eq. 3d) are already merged into
single items, so no equality rows remain. This module turns a `PackingProblem` into plain arrays (CSR rows)
that native solver APIs take directly and that pickle cheaply to a worker process.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from packing import pack_bit_rows

if TYPE_CHECKING:
    import scipy.sparse as sp

    from packing import PackingProblem


@dataclass(frozen=True)
class CliqueModel:
    """``max w.x  s.t.  sum(x[c]) <= 1 for every clique c,  counts.x <= cap,  x binary`` (eq. 3, sec. 6).

    Attributes
    ----------
    weights : (I,) float array
        Objective coefficients (eq. 3a).
    row_starts, row_items : int arrays
        The cliques in CSR form: row r holds items ``row_items[row_starts[r]:row_starts[r + 1]]``.
    shape_counts : (I,) int array
        Blendshapes in each item (a symmetry pair counts 2), the cap row's coefficients.
    cap : int or None
        Right-hand side of the cap row; None when there is none or it cannot bind.
    """

    weights: np.ndarray
    row_starts: np.ndarray
    row_items: np.ndarray
    shape_counts: np.ndarray
    cap: int | None

    @classmethod
    def from_problem(cls, problem: PackingProblem, keep: np.ndarray | None = None) -> CliqueModel:
        """Arrays of a problem's presolved model, or of its sub-problem over the items ``keep`` (ascending;
        item r of the model is ``keep[r]``); a cap that all its items together respect is dropped."""
        weights, counts = np.asarray(problem.weights, dtype=np.float64), problem.item_shape_counts
        if keep is None:
            row_starts, row_items, _ = problem.clique_arrays
        else:
            row_starts, row_items = problem.restricted_conflict_sets(keep)
            weights, counts = weights[keep], counts[keep]
        cap = problem.cap if problem.cap is not None and problem.cap < counts.sum() else None
        return cls(weights, row_starts, row_items, counts, cap)

    @property
    def n_items(self) -> int:
        """Number of binary variables."""
        return int(self.weights.size)

    @property
    def n_rows(self) -> int:
        """Number of clique rows (the cap row not included)."""
        return int(self.row_starts.size - 1)

    def row(self, r: int) -> np.ndarray:
        """Items of clique row ``r``."""
        return self.row_items[self.row_starts[r] : self.row_starts[r + 1]]

    def restricted(self, keep: np.ndarray) -> CliqueModel:
        """The model over the items ``keep`` (ascending; item r of the new model is ``keep[r]``): each row
        cut to its kept items, the rows inside another cut row dropped (`widest_rows`), the cap dropped when
        the kept items together respect it.

        Rows left inside others are implied by them, in the integer model and in its linear relaxation
        alike: dropping them changes neither the packings nor the LP bound, and it takes a third off the
        backends' search on the fixed models of `solvers._fixing` (cutting the maximal cliques of a kernel
        to the half of its items that the fixing keeps leaves seven rows in ten equal to or inside another;
        CP-SAT on the 2,000-shape film sequence's 167 fixed models of 40 items or more: 3.0 -> 1.9 s).
        """
        position = np.full(self.n_items, -1, dtype=np.int64)
        position[keep] = np.arange(keep.size)
        renamed = position[self.row_items]
        inside = renamed >= 0
        row_of = np.repeat(np.arange(self.n_rows), np.diff(self.row_starts))[inside]
        members = np.zeros((self.n_rows, keep.size), dtype=bool)
        members[row_of, renamed[inside]] = True
        rows = members[widest_rows(pack_bit_rows(members))]
        row_of, items = np.divmod(np.flatnonzero(rows), keep.size)  # (as np.nonzero, a third of its time)
        starts = np.zeros(rows.shape[0] + 1, dtype=np.int64)
        np.cumsum(np.bincount(row_of, minlength=rows.shape[0]), out=starts[1:])
        counts = self.shape_counts[keep]
        cap = self.cap if self.cap is not None and self.cap < counts.sum() else None
        return CliqueModel(self.weights[keep], starts, items.astype(self.row_items.dtype), counts, cap)

    def conflict_graph(self) -> sp.csr_matrix:
        """(I, I) symmetric bool CSR adjacency of the items that share a clique row, no self loops, indices
        sorted."""
        import scipy.sparse as sp

        owner = np.repeat(np.arange(self.n_rows), np.diff(self.row_starts))
        rows = sp.csr_matrix(
            (np.ones(self.row_items.size, dtype=np.int32), (owner, self.row_items)),
            shape=(self.n_rows, self.n_items),
        )
        shared = (rows.T @ rows).tocsr()
        shared.setdiag(0)
        shared.eliminate_zeros()
        adjacency = shared.astype(bool)
        adjacency.sort_indices()
        return adjacency

    def matrix(self) -> sp.csr_matrix:
        """(R, I) float CSR matrix of every row: the clique rows, then the cap row when there is one.

        With `upper`, the model's constraints are ``matrix() @ x <= upper()``.
        """
        import scipy.sparse as sp

        starts, items, values = self.row_starts, self.row_items, np.ones(self.row_items.size)
        if self.cap is not None:
            starts = np.append(starts, starts[-1] + self.n_items)
            items = np.concatenate([items, np.arange(self.n_items)])
            values = np.concatenate([values, self.shape_counts.astype(np.float64)])
        return sp.csr_matrix((values, items, starts), shape=(starts.size - 1, self.n_items))

    def upper(self) -> np.ndarray:
        """Right-hand side of every row of `matrix`: 1 per clique, then the cap."""
        ones = np.ones(self.n_rows)
        return ones if self.cap is None else np.append(ones, float(self.cap))

    def constraint(self):
        """The rows as one ``scipy.optimize.LinearConstraint`` (``-inf <= matrix() @ x <= upper()``)."""
        from scipy.optimize import LinearConstraint

        return LinearConstraint(self.matrix(), -np.inf, self.upper())


#: Rows `widest_rows` compares with all the others at once (bounds its temporaries).
WIDEST_BLOCK = 1024


def distinct_bit_rows(words: np.ndarray) -> np.ndarray:
    """Indices of the distinct rows of an (R, W) uint64 array, the first of each in order of the rows
    sorted lexicographically by word (as ``np.unique(words, axis=0, return_index=True)[1]`` over the
    numbers; a sort of W integer keys, where that one compares the rows as opaque bytes)."""
    order = np.lexsort(words.T[::-1])  # (word 0 the primary key; stable, so the first of equal rows first)
    ordered = words[order]
    first = np.ones(order.size, dtype=bool)
    first[1:] = (ordered[1:] != ordered[:-1]).any(axis=1)
    return order[first]


def widest_rows(words: np.ndarray) -> np.ndarray:
    """Indices, ascending, of the rows of an (R, W) uint64 bit array (`packing.pack_bit_rows`) that hold
    at least two items and are inside no other row; of equal rows, the first.

    Notes
    -----
    O(D^2 W) word operations for the D distinct rows of two items or more, `WIDEST_BLOCK` rows against all
    D at a time (O(D) memory per row of the block).
    """
    wide = np.flatnonzero(np.bitwise_count(words).sum(axis=1) >= 2)
    if wide.size == 0:
        return wide
    distinct = np.sort(wide[distinct_bit_rows(words[wide])])
    columns = np.ascontiguousarray(words[distinct].T)  # (W, D): one word of every row at a time
    inside_another = np.zeros(distinct.size, dtype=bool)
    for low in range(0, distinct.size, WIDEST_BLOCK):
        block = slice(low, min(low + WIDEST_BLOCK, distinct.size))
        within = np.ones((block.stop - low, distinct.size), dtype=bool)  # within[a, b]: row a inside row b
        for word in columns:
            within &= (word[block, None] & ~word[None, :]) == 0
        within[np.arange(block.stop - low), np.arange(low, block.stop)] = False  # (a row is inside itself)
        inside_another[block] = within.any(axis=1)
    return distinct[~inside_another]
