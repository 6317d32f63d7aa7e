"""Presolve eq. 3b: from one row per vertex to the distinct maximal conflict sets (docs/architecture.md).

Sets of items are handled as rows of bits (item 0 is the highest bit of the first 64-bit word), so that
equality, containment and the canonical order of sets are word operations. Two entry points: the presolve of
a problem from its vertices (`maximal_conflict_sets`, once per rig), and the presolve of a sub-problem from
the maximal sets of its parent (`ConflictSets.restrict`, every expression of Algorithm 1 and every artist
rejection), which never visits a vertex again.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.sparse as sp


def maximal_conflict_sets(incidence: sp.spmatrix) -> tuple[tuple[np.ndarray, ...], int]:
    """Distinct maximal sets of items that share a vertex.

    Eq. 3b has one row ``sum_k b_k^n w_k <= 1`` per vertex n. A vertex active in fewer than two
    items constrains nothing; two vertices with the same item set give the same row; a row whose
    item set is contained in another row's set is implied by it. What remains is the set of
    inclusion-maximal vertex item sets, which has exactly the same feasible set.

    Parameters
    ----------
    incidence : (I, N) sparse bool matrix
        Active vertices of each item.

    Returns
    -------
    cliques : tuple of int arrays
        Item indices of each maximal set, ascending, each of size >= 2; ordered by decreasing size,
        then lexicographically.
    n_vertex_rows : int
        Number of vertices active in at least one item (the eq. 3b rows that are not empty).

    Notes
    -----
    O(N I / 64) word operations: the vertex item sets of the vertices in two items or more are packed
    into bit rows, sorted to make them unique, and each unique set is compared only with the larger
    sets that hold its rarest item. Vertices are never looped over.
    """
    sets, n_vertex_rows = ConflictSets.from_incidence(incidence)
    return sets.as_tuple(), n_vertex_rows


@dataclass(frozen=True)
class ConflictSets:
    """Distinct maximal conflict sets in flat (CSR) form, in canonical order.

    Set r holds items ``members[starts[r]:starts[r + 1]]``, ascending; sets are ordered by decreasing
    size, then lexicographically by their item lists, over the items ``0..n_items-1``. ``sizes`` and
    ``owner`` (the set of each member) are kept alongside for `restrict`. All arrays are read-only.
    """

    members: np.ndarray
    starts: np.ndarray
    sizes: np.ndarray
    owner: np.ndarray
    n_items: int

    @classmethod
    def from_cliques(cls, cliques: tuple[np.ndarray, ...], n_items: int) -> ConflictSets:
        """The flat form of a tuple of conflict sets over ``n_items`` items (as held by
        `PackingProblem.cliques`)."""
        sizes = np.fromiter((c.size for c in cliques), dtype=np.int64, count=len(cliques))
        members = np.concatenate(cliques).astype(np.int64) if cliques else np.zeros(0, dtype=np.int64)
        return cls._frozen(members, sizes, n_items)

    @classmethod
    def from_incidence(cls, incidence: sp.spmatrix) -> tuple[ConflictSets, int]:
        """The maximal conflict sets of an item-by-vertex incidence and the number of non-empty vertex rows
        (see `maximal_conflict_sets`)."""
        incidence = sp.csr_matrix(incidence, dtype=bool)
        if not (incidence.has_canonical_format and incidence.data.all()):
            incidence = incidence.copy()  # its index arrays may be the caller's
            incidence.sum_duplicates()
            incidence.eliminate_zeros()
        n_items, n_vertices = incidence.shape
        vertex_sizes = np.bincount(incidence.indices, minlength=n_vertices)
        n_vertex_rows = int(np.count_nonzero(vertex_sizes))
        conflicted = vertex_sizes >= 2  # one eq. 3b row each, to be reduced
        n_rows = int(np.count_nonzero(conflicted))
        if n_rows == 0:
            empty = np.zeros(0, dtype=np.int64)
            return cls._frozen(empty, empty.copy(), n_items), n_vertex_rows
        # (32-bit entries: a film-sized incidence has millions, and they are the presolve's largest arrays)
        row_of_vertex = (np.cumsum(conflicted) - 1).astype(np.int32)
        inside = conflicted[incidence.indices]
        entry_row = row_of_vertex[incidence.indices[inside]]  # entries grouped by item (CSR order)
        entry_item = np.repeat(np.arange(n_items, dtype=np.int32), np.diff(incidence.indptr))[inside]
        words, sizes = _words(_bit_rows(entry_row, entry_item, n_rows, n_items)), vertex_sizes[conflicted]
        order = _canonical_order(words, sizes)
        first = np.ones(n_rows, dtype=bool)  # first row of each run of equal sets in canonical order
        first[1:] = _differ(words, order[1:], order[:-1])
        unique = order[first]
        set_of_row = np.empty(n_rows, dtype=np.int64)
        set_of_row[order] = np.cumsum(first) - 1
        representative = np.zeros(n_rows, dtype=bool)
        representative[unique] = True
        mine = representative[entry_row]
        dominated = _dominated_by_larger(
            set_of_row[entry_row[mine]], entry_item[mine], _take(words, unique), sizes[unique], n_items
        )
        maximal = unique[~dominated]
        _, members = np.nonzero(unpack_bit_rows(np.ascontiguousarray(_take(words, maximal).T), n_items))
        return cls._frozen(members.astype(np.int64), sizes[maximal], n_items), n_vertex_rows

    @classmethod
    def _frozen(cls, members: np.ndarray, sizes: np.ndarray, n_items: int) -> ConflictSets:
        starts = np.zeros(sizes.size + 1, dtype=np.int64)
        sizes.cumsum(out=starts[1:])
        owner = np.arange(sizes.size).repeat(sizes)
        for array in (members, starts, sizes, owner):
            array.flags.writeable = False
        return cls(members, starts, sizes, owner, n_items)

    def __len__(self) -> int:
        return self.sizes.size

    @cached_property
    def holders(self) -> tuple[np.ndarray, np.ndarray]:
        """The sets holding each item, in flat (CSR) form: ``(holder_starts, holder_sets)``, item i in sets
        ``holder_sets[holder_starts[i]:holder_starts[i + 1]]`` (ascending). Computed on first use, in O(M)
        for the M members (the transpose of the sets' CSR incidence, a counting sort)."""
        incidence = sp.csr_matrix(
            (np.ones(self.members.size, dtype=np.int8), self.members, self.starts),
            shape=(len(self), self.n_items),
        )
        by_item = incidence.tocsc()
        holder_starts = by_item.indptr.astype(np.int64)
        holder_sets = by_item.indices.astype(np.int64)
        holder_starts.flags.writeable = holder_sets.flags.writeable = False
        return holder_starts, holder_sets

    @cached_property
    def closed_bits(self) -> np.ndarray:
        """(I, W) read-only uint64 array: the closed neighbourhoods of the item conflict graph as bit rows.

        Bit j of row i (item j is bit ``63 - j % 64`` of word ``j // 64``, `np.packbits` order) is set when
        items i and j share a set, or i = j. O(M W) for the M members: each item's row is the OR of the bit
        rows of the sets holding it.
        """
        closed = pack_bit_rows(np.eye(self.n_items, dtype=bool))
        if self.members.size:
            sets = np.zeros((len(self), self.n_items), dtype=bool)
            sets[self.owner, self.members] = True
            holder_starts, holder_sets = self.holders
            holders = np.flatnonzero(np.diff(holder_starts))
            words = pack_bit_rows(sets)[holder_sets]
            closed[holders] |= np.bitwise_or.reduceat(words, holder_starts[holders], axis=0)
        closed.flags.writeable = False
        return closed

    @cached_property
    def neighbours(self) -> tuple[np.ndarray, np.ndarray]:
        """The closed neighbourhoods of `closed_bits` in flat (CSR) form, ``(starts, items)``: item i and the
        items it shares a set with are ``items[starts[i]:starts[i + 1]]``, ascending. Each item's list is
        its distinct neighbours, where the members of the sets holding it repeat an item once per set
        shared (on film-sized rigs a hundred times)."""
        rows, items = np.nonzero(unpack_bit_rows(self.closed_bits, self.n_items))
        starts = np.zeros(self.n_items + 1, dtype=np.int64)
        np.cumsum(np.bincount(rows, minlength=self.n_items), out=starts[1:])
        items = items.astype(np.int64)
        starts.flags.writeable = items.flags.writeable = False
        return starts, items

    @property
    def has_neighbours(self) -> bool:
        """Whether `neighbours` is made already."""
        return "neighbours" in self.__dict__

    def as_tuple(self) -> tuple[np.ndarray, ...]:
        """The sets as a tuple of read-only int arrays (views of `members`)."""
        members, bounds = self.members, self.starts.tolist()
        return tuple(members[a:b] for a, b in zip(bounds[:-1], bounds[1:], strict=True))

    def restrict(self, kept: np.ndarray) -> ConflictSets:
        """The maximal conflict sets over the items where the bool mask ``kept`` is True, renumbered
        ``0, 1, ...`` in their order.

        Each set ``C`` becomes ``C & kept``; sets left with fewer than two items go. A set that kept all
        its items stays maximal (it was not inside another set before, so it is not inside a smaller
        one now) and stays distinct; only the sets that lost items can have become duplicates or
        subsets of others, and only those are compared, with every set, as bit rows.

        Notes
        -----
        O(M) for the M members of the sets, plus O(c S I / 64) word operations for the c sets that lost
        items against the S sets, in a fixed number of numpy calls. Requires the sets to be distinct,
        maximal and in canonical order, as `from_incidence` and `restrict` make them; then so are the
        new ones.
        """
        inside = kept[self.members]
        owner, members = self.owner[inside], (kept.cumsum() - 1)[self.members[inside]]
        sizes = np.bincount(owner, minlength=len(self))
        alive = sizes >= 2
        shrunk = alive & (sizes < self.sizes)
        n_kept = int(np.count_nonzero(kept))
        if not shrunk.any():  # unchanged sets, renumbered, in the same order
            return self._frozen(members[alive[owner]], sizes[alive], n_kept)
        words = _words(_bit_rows(owner, members, len(self), n_kept))
        retained = alive & ~_dominated_among(words, sizes, shrunk.nonzero()[0], owner, members, n_kept)
        order = _canonical_order(words, sizes, retained)
        start = (sizes.cumsum() - sizes)[order]  # where each set's members are (grouped by set)
        sizes = sizes[order]
        ahead = sizes.cumsum() - sizes  # where they go
        take = (start - ahead).repeat(sizes) + np.arange(ahead[-1] + sizes[-1])
        return self._frozen(members[take], sizes, n_kept)


class LazyConflictSets:
    """The conflict sets of a problem, known or derived from an ancestor's on first use.

    A restriction (`PackingProblem.restrict`) records only which of its parent's items it keeps. Its sets
    are computed when asked, by one `ConflictSets.restrict` of the nearest ancestor whose sets are known
    with the composed selection of items (a chain of restrictions gives the sets one restriction gives),
    and the link to the parent is then let go. A consumer that only needs to know which items conflict
    (Algorithm 2) reads the ancestor's sets through `view` and derives nothing.

    Parameters
    ----------
    sets : ConflictSets or None
        The sets, when known.
    parent : LazyConflictSets, optional
        The sets of the problem restricted, when ``sets`` is not given.
    index : (n_items,) int array, optional
        The kept items among the parent's, ascending.
    """

    def __init__(
        self,
        sets: ConflictSets | None,
        parent: LazyConflictSets | None = None,
        index: np.ndarray | None = None,
    ) -> None:
        self._sets, self._parent, self._index = sets, parent, index
        self._view: ConflictView | None = None
        self.n_items = sets.n_items if sets is not None else index.size

    def __getstate__(self) -> dict[str, object]:
        """Only the computed sets (a pickled copy does not carry its ancestors)."""
        sets = self.value()
        return {"_sets": sets, "_parent": None, "_index": None, "_view": None, "n_items": self.n_items}

    @property
    def known(self) -> bool:
        """Whether the sets are computed."""
        return self._sets is not None

    def restricted(self, index: np.ndarray) -> LazyConflictSets:
        """The sets of the problem over the items ``index`` (ascending) of this one, derived on first use."""
        return LazyConflictSets(None, self, index)

    def view(self) -> ConflictView:
        """These sets once computed, else the view of the nearest problem up the lineage whose sets are known
        (kept for the restrictions of this one: a sequence of restrictions walks one step each)."""
        if self._sets is not None:
            return ConflictView(self._sets, np.arange(self.n_items))
        if self._view is None:
            walked, node = [], self
            while node._sets is None and node._view is None:
                walked.append(node)
                node = node._parent
            view = node.view()
            for node in reversed(walked):
                view = node._view = ConflictView(view.sets, view.items[node._index])
        return self._view

    def value(self) -> ConflictSets:
        """The sets, computed on the first call by one restriction of the nearest known ancestor's; the
        lineage is then let go."""
        if self._sets is None:
            node, index = self, np.arange(self.n_items)
            while node._sets is None:
                index = node._index[index]
                node = node._parent
            kept = np.zeros(node.n_items, dtype=bool)
            kept[index] = True
            self._sets = node._sets.restrict(kept)
            self._parent = self._index = self._view = None
        return self._sets


@dataclass(frozen=True)
class ConflictView:
    """Conflict sets over a superset of a problem's items: two items of the problem conflict iff they share
    one of these sets, as they do iff they share one of the problem's own (maximal) sets.

    Attributes
    ----------
    sets : ConflictSets
        The sets, over ``sets.n_items`` items.
    items : (I,) int array
        The problem's items among them, ascending.
    """

    sets: ConflictSets
    items: np.ndarray


def pack_bit_rows(rows: np.ndarray) -> np.ndarray:
    """(n, W) uint64 words of n bool rows, column 0 the highest bit of word 0 (`np.packbits` order)."""
    width = -(-rows.shape[1] // 64) * 64
    padded = np.zeros((rows.shape[0], width), dtype=bool)
    padded[:, : rows.shape[1]] = rows
    return np.packbits(padded, axis=1).view(">u8").astype(np.uint64)


def unpack_bit_rows(words: np.ndarray, n_columns: int) -> np.ndarray:
    """The bool rows of `pack_bit_rows` words."""
    return np.unpackbits(words.astype(">u8").view(np.uint8), axis=1, count=n_columns).astype(bool)


def _bit_rows(rows: np.ndarray, cols: np.ndarray, n_rows: int, n_cols: int) -> np.ndarray:
    """(n_rows, 64 W) bool matrix with ones at ``(rows, cols)``, W the 64-bit words needed for n_cols."""
    width = -(-n_cols // 64) * 64
    dense = np.zeros(n_rows * width, dtype=bool)
    dense[rows.astype(np.int64) * width + cols] = True
    return dense.reshape(n_rows, width)


def _words(rows: np.ndarray) -> np.ndarray:
    """(W, n) uint64 words of n bool rows, word-major; column 0 of the rows is the highest bit of word 0,
    so the numeric order of the words is the reverse lexicographic order of equally large sets."""
    return np.ascontiguousarray(np.packbits(rows, axis=1).view(">u8").astype(np.uint64).T)


def _canonical_order(words: np.ndarray, sizes: np.ndarray, selected: np.ndarray | None = None) -> np.ndarray:
    """Indices of the sets (of the ``selected`` ones, if given) by decreasing size, then lexicographically
    by their ascending item lists."""
    keys = [*~words[::-1], -sizes]
    if selected is None:
        return np.lexsort(keys)
    return np.lexsort([*keys, ~selected])[: np.count_nonzero(selected)]


def _take(words: np.ndarray, index: np.ndarray) -> np.ndarray:
    """(W, len(index)) words of the sets ``index`` (word by word: contiguous one-dimensional gathers)."""
    return np.stack([word[index] for word in words])


def _differ(words: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Bool array: sets ``a`` and ``b`` (index arrays that broadcast) differ."""
    differ = words[0][a] != words[0][b]
    for word in words[1:]:
        differ |= word[a] != word[b]
    return differ


def _not_inside(words: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Bool array: set ``a`` is not a subset of set ``b`` (index arrays that broadcast). Word by word, on
    the pairs still inside: most pairs are told apart by their first words."""
    a, b = np.broadcast_arrays(a, b)
    inside = np.arange(a.size)
    pair_a, pair_b = a.ravel(), b.ravel()
    for word in words:
        keep = (word[pair_a] & ~word[pair_b]) == 0
        inside, pair_a, pair_b = inside[keep], pair_a[keep], pair_b[keep]
    outside = np.ones(a.shape, dtype=bool)
    outside.reshape(-1)[inside] = False
    return outside


#: Set pairs `_dominated_by_larger` compares at once (bounds its temporaries to about 10 MB).
_PAIRS_PER_BLOCK = 1 << 18
#: How many of the larger sets holding its rarest item `_dominated_by_larger` compares a set with before
#: the next stage (largest first; the last stage compares the rest).
_STAGES = (8, 64)


def _dominated_by_larger(
    entry_set: np.ndarray, entry_item: np.ndarray, words: np.ndarray, sizes: np.ndarray, n_items: int
) -> np.ndarray:
    """(S,) bool: distinct sets contained in a larger one.

    ``entry_set`` and ``entry_item`` list the members of the sets, grouped by item. Each set is compared
    only with the larger sets that hold its rarest item, largest first and in stages (`_STAGES`): a set
    found inside one is not compared again. A contained set lies in many of those (on film rigs in a
    quarter of them), so the stages halve the comparisons. About `_PAIRS_PER_BLOCK` pairs are compared at a
    time.
    """
    n_sets = sizes.size
    holders = np.bincount(entry_item, minlength=n_items)  # sets holding each item
    first_holder = np.zeros(n_items + 1, dtype=np.int64)
    np.cumsum(holders, out=first_holder[1:])
    by_size = np.argsort(-sizes, kind="stable")
    rank = np.empty(n_sets, dtype=np.int64)
    rank[by_size] = np.arange(n_sets)
    held = sp.csr_matrix(
        (np.ones(entry_set.size, dtype=bool), rank[entry_set], first_holder), shape=(n_items, n_sets)
    )
    largest_first = by_size[held.tocsc().tocsr().indices]  # the holders of each item, by decreasing size
    rarest = np.full(n_sets, np.iinfo(np.int64).max, dtype=np.int64)
    np.minimum.at(rarest, entry_set, holders[entry_item] * n_items + entry_item)
    rarest %= n_items
    # The holders larger than a set lead its rarest item's list: key (item, largest size first).
    top = int(sizes.max(initial=0))
    key = np.repeat(np.arange(n_items, dtype=np.int64), holders) * (top + 1) + (top - sizes[largest_first])
    n_larger = np.searchsorted(key, rarest * (top + 1) + (top - sizes)) - first_holder[rarest]
    dominated = np.zeros(n_sets, dtype=bool)
    low = 0
    for high in (*_STAGES, None):
        alive = np.flatnonzero(~dominated & (n_larger > low))
        if alive.size == 0:
            break
        counts = n_larger[alive] - low if high is None else np.minimum(n_larger[alive], high) - low
        pairs_before = np.zeros(alive.size + 1, dtype=np.int64)
        np.cumsum(counts, out=pairs_before[1:])
        marks = np.arange(0, pairs_before[-1], _PAIRS_PER_BLOCK)
        bounds = np.searchsorted(pairs_before, marks, side="right") - 1
        for start, stop in zip(bounds.tolist(), [*bounds[1:].tolist(), alive.size], strict=True):
            block = slice(start, stop)
            subset = np.repeat(alive[block], counts[block])
            offset = np.arange(subset.size) - np.repeat(
                pairs_before[block] - pairs_before[start] - low, counts[block]
            )
            superset = largest_first[np.repeat(first_holder[rarest[alive[block]]], counts[block]) + offset]
            dominated[subset[~_not_inside(words, subset, superset)]] = True
        low = high
    return dominated


#: Word comparisons below which `_dominated_among` compares every candidate with every set at once.
_DENSE_COMPARISONS = 1 << 16


def _dominated_among(
    words: np.ndarray,
    sizes: np.ndarray,
    candidates: np.ndarray,
    owner: np.ndarray,
    members: np.ndarray,
    n_items: int,
) -> np.ndarray:
    """(S,) bool: candidate sets contained in a larger set, or equal to a set listed before them.

    Of a group of equal sets the first is kept (unless it lies in a larger set); sets that are not
    candidates are never dominated. A set ``y`` dominates a contained set ``x`` when it ranks higher:
    larger, or as large (then equal) and earlier. ``owner`` and ``members`` list the members of the sets,
    grouped by set in set order, over ``n_items`` items. Few candidates are compared with every set at once;
    otherwise each candidate (ascending) is compared only with the sets that hold its rarest item, which
    every set containing it does.
    """
    n_sets = sizes.size
    rank = sizes * n_sets - np.arange(n_sets)
    if candidates.size * n_sets * words.shape[0] <= _DENSE_COMPARISONS:
        contained = ~(words[:, candidates, None] & ~words[:, None, :]).any(axis=0)  # (candidates, S)
        dominated = np.zeros(n_sets, dtype=bool)
        dominated[candidates] = (contained & (rank > rank[candidates, None])).any(axis=1)
        return dominated
    holders = np.bincount(members, minlength=n_items)  # sets holding each item
    candidate = np.zeros(n_sets, dtype=bool)
    candidate[candidates] = True
    inside = candidate[owner]
    keys, groups = holders[members[inside]] * n_items + members[inside], owner[inside]
    firsts = np.flatnonzero(np.concatenate([[True], groups[1:] != groups[:-1]]))
    rarest = np.minimum.reduceat(keys, firsts) % n_items  # of each candidate, in ascending order
    wanted = np.zeros(n_items, dtype=bool)
    wanted[rarest] = True
    holding = np.flatnonzero(wanted[members])  # the members that are some candidate's rarest item
    by_item = np.argsort(members[holding], kind="stable")
    items, sets = members[holding][by_item], owner[holding][by_item]
    counts = holders[rarest]
    subset = np.repeat(candidates, counts)
    offset = np.arange(subset.size) - np.repeat(np.cumsum(counts) - counts, counts)
    superset = sets[np.repeat(np.searchsorted(items, rarest), counts) + offset]
    higher = rank[superset] > rank[subset]
    subset, superset = subset[higher], superset[higher]
    dominated = np.zeros(n_sets, dtype=bool)
    dominated[subset[~_not_inside(words, subset, superset)]] = True
    return dominated
