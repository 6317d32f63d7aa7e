"""The packing problem handed to solvers: items, weights, presolved conflict sets, cap (eq. 3, sec. 6)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, fields, replace
from functools import cached_property
from typing import Any

import numpy as np
import scipy.sparse as sp

from packing._deferred import Deferred, DeferredField, computed_state
from packing._presolve import ConflictSets, ConflictView, LazyConflictSets, pack_bit_rows, unpack_bit_rows


@dataclass(frozen=True, eq=False)
class PackingProblem:
    """One expression's weighted set-packing problem (Carrigan et al. 2020, eq. 3).

    An *item* is a blendshape, or a symmetry pair forced together (eq. 3d) merged into one item whose
    active vertex set is the union of both and whose weight is the sum (sec. 4.4). Solvers choose a set
    of items; at most one item of every conflict set may be chosen (eq. 3b after presolve), and the
    shapes of the chosen items may not exceed ``cap`` (sec. 6).

    Parameters
    ----------
    shape_names : tuple of str
        Names of every blendshape of the rig (item shapes index into this).
    items : tuple of tuple of int
        Rig shape indices of each item: one index, or two for a symmetry pair.
    weights : (I,) float array
        Objective coefficient of each item: the importance (eq. 4) summed over its shapes, plus a
        deterministic tie-break perturbation (see `packing.build_problem`).
    incidence : (I, N) scipy.sparse CSR bool matrix
        Active vertices of each item (eq. 2; the union for pairs). Kept for heuristics that measure
        overlap and for the naive per-vertex baseline model.
    cliques : tuple of int arrays
        Presolved constraints: the distinct maximal sets of item indices that share a vertex, each of
        size >= 2. ``sum(w[c]) <= 1`` for each is equivalent to eq. 3b for every vertex.
    cap : int or None
        Maximum number of blendshapes per expression (sec. 6), counting both shapes of a pair.
    n_vertex_rows : int
        Number of eq. 3b rows before presolve (vertices active in at least one item).
    meta : mapping
        Provenance: parameters, timings of the build and presolve.
    tie_break : (I,) float array, optional
        The deterministic perturbation included in ``weights`` (see `packing.build_problem`); the
        unperturbed objective of a set of items is ``objective(items) - tie_break[items].sum()``.
    apart : tuple of (int, int)
        Item pairs that may not share an expression although they share no vertex (artist constraints,
        `packing._constraints`). They are already among ``cliques``; a solver that reads ``incidence``
        instead of ``cliques`` must add ``w_a + w_b <= 1`` for each.
    """

    shape_names: tuple[str, ...]
    items: tuple[tuple[int, ...], ...]
    weights: np.ndarray
    incidence: sp.csr_matrix = DeferredField()  # type: ignore[assignment]
    cliques: tuple[np.ndarray, ...] = DeferredField()  # type: ignore[assignment]
    cap: int | None = None
    n_vertex_rows: int = 0
    meta: Mapping[str, Any] = field(default_factory=dict)
    tie_break: np.ndarray | None = None
    apart: tuple[tuple[int, int], ...] = ()

    def __getstate__(self) -> dict[str, Any]:
        """The instance dictionary with every deferred value computed (a `Deferred` holds a function, which
        does not pickle)."""
        return computed_state(self)

    @property
    def n_items(self) -> int:
        """I, the number of items."""
        return len(self.items)

    @cached_property
    def item_shape_counts(self) -> np.ndarray:
        """(I,) read-only int array: blendshapes in each item (1, or 2 for a pair); the cap counts these."""
        counts = np.fromiter(map(len, self.items), dtype=np.int64, count=len(self.items))
        counts.flags.writeable = False
        return counts

    @cached_property
    def item_active_counts(self) -> np.ndarray:
        """(I,) read-only int array: active vertices of each item, ``|b_k|`` in Algorithm 2."""
        counts = np.asarray(self.incidence.sum(axis=1)).ravel().astype(np.int64)
        counts.flags.writeable = False
        return counts

    @property
    def clique_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``cliques`` in flat (CSR) form, read-only: ``starts`` (R + 1,), ``members`` (M,) and ``owner``
        (M,), set r holding items ``members[starts[r]:starts[r + 1]]`` and ``owner`` naming the set of each
        member. Computed once per problem (a restriction derives it with its conflict sets)."""
        sets = self._conflict_sets
        return sets.starts, sets.members, sets.owner

    def item_label(self, item: int) -> str:
        """Human-readable label: the shape name, or ``a+b`` for a pair."""
        return "+".join(self.shape_names[k] for k in self.items[item])

    def shapes_of(self, chosen: Iterable[int]) -> tuple[str, ...]:
        """Names of the blendshapes in the chosen items, in item order."""
        return tuple(self.shape_names[k] for i in sorted(chosen) for k in self.items[i])

    def objective(self, chosen: Iterable[int]) -> float:
        """Objective value (eq. 3a) of a set of items."""
        return float(self.weights[np.fromiter(chosen, dtype=np.int64)].sum())

    def unperturbed_objective(self, chosen: Iterable[int]) -> float:
        """Objective of a set of items without the tie-break perturbation (the importance sum)."""
        index = np.fromiter(chosen, dtype=np.int64)
        perturbation = 0.0 if self.tie_break is None else float(self.tie_break[index].sum())
        return float(self.weights[index].sum()) - perturbation

    def restrict(self, keep: Iterable[int], *, meta: Mapping[str, Any] | None = None) -> PackingProblem:
        """The same problem over a subset of its items (renumbered in ascending order), presolved anew.

        Used by the expression sequence (Algorithm 1 removes the items already used) and by artist
        refinement (sec. 4.5.3 excludes rejected items from the current expression). The new conflict
        sets are derived from this problem's maximal sets, not from the vertices
        (`packing._presolve.ConflictSets.restrict`), and the count of vertex rows from this problem's
        count of items per vertex, less the dropped items' vertices.

        Parameters
        ----------
        keep : iterable of int
            Items kept.
        meta : mapping, optional
            Entries to add to the restricted problem's meta.

        Notes
        -----
        Lazy: ``incidence`` (the kept rows of the matrix this problem's rows come from), ``cliques``, the
        conflict sets behind `clique_arrays` and ``conflict_bits`` are derived on first read, so a solver
        that reads only some of them (greedy reads the conflict sets, weights and counts) pays for those
        only. Eager work is O(I + the dropped items' vertices) in a fixed number of numpy calls. A chain
        of restrictions (the expression sequence) gives exactly the problem that one restriction of the
        first would.
        """
        keep_index = _item_index(keep, self.n_items)
        kept = np.zeros(self.n_items, dtype=bool)
        kept[keep_index] = True
        matrix, rows = self._incidence_rows
        dropped_vertices = _row_vertices(matrix, rows[~kept])
        cover = self._vertex_cover - np.bincount(dropped_vertices, minlength=matrix.shape[1])
        rows = rows[keep_index]
        sets = self._lineage().restricted(keep_index)
        weights = self.weights[keep_index]
        weights.flags.writeable = False
        derived: dict[str, Any] = {
            "_conflict_sets": sets,
            "_vertex_cover": cover,
            "_incidence_rows": (matrix, rows),
        }
        for name in ("item_shape_counts", "item_active_counts"):
            counts = getattr(self, name)[keep_index]
            counts.flags.writeable = False
            derived[name] = counts
        if "conflict_bits" in self.__dict__:
            derived["conflict_bits"] = _selected_bits(self.conflict_bits, keep_index, self.n_items)
        restricted = _raw_replace(
            self,
            items=tuple(map(self.items.__getitem__, keep_index.tolist())),
            weights=weights,
            incidence=Deferred(lambda: _select_rows(matrix, rows)),
            cliques=Deferred(lambda: sets.value().as_tuple()),
            n_vertex_rows=int(np.count_nonzero(cover)),
            meta={**_restricted_meta(self.meta, keep_index), **(meta or {})},
            tie_break=None if self.tie_break is None else self.tie_break[keep_index],
            apart=_restricted_pairs(self.apart, kept),
        )
        return _with_structure(restricted, **derived)

    @property
    def n_cliques(self) -> int:
        """Number of conflict sets, ``len(cliques)``, without building the tuple of a restricted problem."""
        if isinstance(self.__dict__.get("_cliques_value"), Deferred):
            return len(self._conflict_sets)
        return len(self.cliques)

    def deferred_n_cliques(self) -> int | Deferred:
        """`n_cliques` if this problem's conflict sets are known, else a `Deferred` of it that holds only what
        derives the sets (for a record of the problem that a solver may not need the sets for)."""
        lineage = self._lineage()
        if lineage.known or not isinstance(self.__dict__.get("_cliques_value"), Deferred):
            return self.n_cliques
        return Deferred(lambda: len(lineage.value()))

    @property
    def conflict_view(self) -> ConflictView:
        """Conflict sets over a superset of the items, with which items conflict exactly as they do in
        `cliques`: this problem's own when computed, else the nearest computed ones of the problems it was
        restricted from (`LazyConflictSets`). What a solver that only asks which items conflict reads,
        without deriving this problem's maximal sets."""
        return self._lineage().view()

    def permuted(self, order: Iterable[int]) -> PackingProblem:
        """The same problem with its items in another order: item ``i`` of the result is item ``order[i]``.

        Weights, tie-break, incidence rows and ``meta["item_index"]`` follow the items; conflict sets and
        apart pairs are relabelled (no presolve is redone, so the conflict sets are the same sets). A
        solution ``items`` of the result is ``order[items]`` here, with the same objective.

        Raises
        ------
        ValueError
            When ``order`` is not a permutation of ``0..n_items-1``.
        """
        order = np.fromiter(order, dtype=np.int64)
        if order.shape != (self.n_items,) or not np.array_equal(np.sort(order), np.arange(self.n_items)):
            raise ValueError(f"permuted: need a permutation of 0..{self.n_items - 1}, got {order.tolist()}")
        position = np.empty_like(order)
        position[order] = np.arange(order.size)
        weights = self.weights[order]
        weights.flags.writeable = False
        meta = dict(self.meta)
        if "item_index" in meta:
            meta["item_index"] = np.asarray(meta["item_index"])[order]
        reordered = replace(
            self,
            items=tuple(self.items[i] for i in order.tolist()),
            weights=weights,
            incidence=self.incidence[order],
            cliques=tuple(np.sort(position[members]).astype(members.dtype) for members in self.cliques),
            meta=meta,
            tie_break=None if self.tie_break is None else self.tie_break[order],
            apart=tuple(sorted(tuple(sorted((int(position[a]), int(position[b])))) for a, b in self.apart)),
        )
        return _with_structure(reordered, _vertex_cover=self._vertex_cover)

    @cached_property
    def conflict_bits(self) -> np.ndarray:
        """(I, W) read-only uint64 array: the closed neighbourhoods of the item conflict graph as bit rows.

        Bit j of row i (item j is bit ``63 - j % 64`` of word ``j // 64``, `np.packbits` order) is set when
        items i and j share a conflict set, or i = j. Computed from the conflict sets on first use in
        O(M W) for their M members; `restrict` derives it from this problem's when this one has it.
        """
        return self._conflict_sets.closed_bits

    def restricted_conflict_sets(self, keep: Iterable[int]) -> tuple[np.ndarray, np.ndarray]:
        """The conflict sets that ``restrict(keep)`` would have, in flat form, without building it.

        Returns ``(starts, members)`` as `clique_arrays` gives them, over the kept items renumbered in
        ascending order. For a backend that needs only the constraints of a sub-problem (the kernel left
        by `solvers`' exact reductions); the vertices are not touched.
        """
        keep_index = _item_index(keep, self.n_items)
        kept = np.zeros(self.n_items, dtype=bool)
        kept[keep_index] = True
        sets = self._conflict_sets.restrict(kept)
        return sets.starts, sets.members

    def reweighted(self, weights: np.ndarray, tie_break: np.ndarray | None = None) -> PackingProblem:
        """The same items and conflict sets with new objective coefficients (no new presolve)."""
        weights = np.array(weights, dtype=np.float64).ravel()
        if weights.shape != (self.n_items,) or not np.isfinite(weights).all():
            raise ValueError(f"reweighted: need {self.n_items} finite weights, got shape {weights.shape}")
        weights.flags.writeable = False
        reweighted = _raw_replace(
            self, weights=weights, tie_break=tie_break if tie_break is not None else self.tie_break
        )
        return _with_structure(reweighted, **_structure_of(self))

    @property
    def _conflict_sets(self) -> ConflictSets:
        """`cliques` in flat form, for `restrict` (derived from the tuple, or by a restriction)."""
        return self._lineage().value()

    def _lineage(self) -> LazyConflictSets:
        """`_conflict_sets`, known or derived on first use, holding none of this problem's other data."""
        lineage = self.__dict__.get("_conflict_sets")
        if lineage is None:
            lineage = LazyConflictSets(ConflictSets.from_cliques(self.cliques, self.n_items))
            self.__dict__["_conflict_sets"] = lineage
        return lineage

    @cached_property
    def _incidence_rows(self) -> tuple[sp.csr_matrix, np.ndarray]:
        """The matrix this problem's incidence rows are taken from, and which of its rows."""
        return self.incidence, np.arange(self.n_items)

    @cached_property
    def _vertex_cover(self) -> np.ndarray:
        """(N,) int array: items active at each vertex (eq. 3b row sums of all items), for `restrict`."""
        return np.bincount(
            _active_vertices(self.incidence.indices, self.incidence.data), minlength=self.incidence.shape[1]
        )


#: The fields a restriction may leave `Deferred`.
_DEFERRED = ("incidence", "cliques")


def with_meta(problem: PackingProblem, **meta: Any) -> PackingProblem:
    """``problem`` with entries added to its meta (structure caches kept: no presolve is redone)."""
    return _with_structure(_raw_replace(problem, meta={**problem.meta, **meta}), **_structure_of(problem))


#: Cached values of a problem that depend on its items and incidence only, not on its weights.
_STRUCTURE = (
    "_conflict_sets",
    "_vertex_cover",
    "_incidence_rows",
    "item_shape_counts",
    "item_active_counts",
    "conflict_bits",
)


def _raw_replace(problem: PackingProblem, **changes: Any) -> PackingProblem:
    """``problem`` with some fields changed and the others as they are: deferred ones are not computed
    (`dataclasses.replace` would read, and so compute, every field). No cached value is carried."""
    slots = {f.name: f"_{f.name}_value" if f.name in _DEFERRED else f.name for f in fields(PackingProblem)}
    changed = object.__new__(PackingProblem)
    changed.__dict__.update({slot: problem.__dict__[slot] for slot in slots.values()})
    for name, value in changes.items():
        object.__setattr__(changed, name, value)
    return changed


def _with_structure(problem: PackingProblem, **cached: Any) -> PackingProblem:
    """``problem`` with structure values already known (the `cached_property` values of `_STRUCTURE`,
    which live in the instance dictionary; a frozen dataclass only forbids assigning fields)."""
    problem.__dict__.update(cached)
    return problem


def _structure_of(problem: PackingProblem) -> dict[str, Any]:
    """The structure values of ``problem`` computed so far."""
    return {name: problem.__dict__[name] for name in _STRUCTURE if name in problem.__dict__}


def _selected_bits(bits: np.ndarray, keep: np.ndarray, n_items: int) -> np.ndarray:
    """The bit rows and columns of the items ``keep`` of `PackingProblem.conflict_bits`, repacked."""
    selected = pack_bit_rows(unpack_bit_rows(bits[keep], n_items)[:, keep])
    selected.flags.writeable = False
    return selected


def _item_index(keep: Iterable[int], n_items: int) -> np.ndarray:
    """Ascending distinct item indices from any iterable of them, checked against ``0..n_items-1``."""
    if isinstance(keep, np.ndarray):
        index = keep.astype(np.int64, copy=False).ravel()
    else:
        index = np.fromiter(keep, dtype=np.int64)
    if index.size > 1 and not (index[1:] > index[:-1]).all():
        index = np.unique(index)
    if index.size and (index[0] < 0 or index[-1] >= n_items):
        raise ValueError(f"restrict: item indices must be in 0..{n_items - 1}, got {index.tolist()}")
    return index


def _select_rows(matrix: sp.csr_matrix, rows: np.ndarray) -> sp.csr_matrix:
    """The rows ``rows`` (ascending) of a CSR bool matrix, canonical flag kept. The rows are copied a run
    of consecutive rows at a time."""
    indptr, indices, data = matrix.indptr, matrix.indices, matrix.data
    breaks = (np.flatnonzero(np.diff(rows) != 1) + 1).tolist()
    bounds = zip([0, *breaks], [*breaks, rows.size], strict=True)
    spans = [(int(indptr[rows[a]]), int(indptr[rows[b - 1] + 1])) for a, b in bounds if b > a]
    selected_indptr = np.zeros(rows.size + 1, dtype=indptr.dtype)
    (indptr[rows + 1] - indptr[rows]).cumsum(out=selected_indptr[1:])
    selected = sp.csr_matrix(
        (
            np.concatenate([data[a:b] for a, b in spans] or [data[:0]]),
            np.concatenate([indices[a:b] for a, b in spans] or [indices[:0]]),
            selected_indptr,
        ),
        shape=(rows.size, matrix.shape[1]),
    )
    if matrix.has_canonical_format:
        selected.has_canonical_format = True
    return selected


def _row_vertices(matrix: sp.csr_matrix, rows: np.ndarray) -> np.ndarray:
    """Column indices of the True entries of the rows ``rows`` of a CSR bool matrix."""
    indptr, indices, data = matrix.indptr, matrix.indices, matrix.data
    spans = list(zip(indptr[rows].tolist(), indptr[rows + 1].tolist(), strict=True))
    return _active_vertices(
        np.concatenate([indices[a:b] for a, b in spans] or [indices[:0]]),
        np.concatenate([data[a:b] for a, b in spans] or [data[:0]]),
    )


def _restricted_pairs(pairs: tuple[tuple[int, int], ...], kept: np.ndarray) -> tuple[tuple[int, int], ...]:
    """Item pairs with both items kept, renumbered like `PackingProblem.restrict` renumbers items."""
    number = kept.cumsum() - 1
    return tuple((int(number[a]), int(number[b])) for a, b in pairs if kept[a] and kept[b])


def _active_vertices(indices: np.ndarray, data: np.ndarray) -> np.ndarray:
    """Column indices of the True entries among CSR entries."""
    return indices if data.all() else indices[data]


def _restricted_meta(meta: Mapping[str, Any], keep: np.ndarray) -> dict[str, Any]:
    """Meta of a restricted problem; ``item_index`` (items of an originating problem) follows the items."""
    restricted = dict(meta)
    if "item_index" in restricted:
        restricted["item_index"] = np.asarray(restricted["item_index"])[keep]
    return restricted


def problem_from_incidence(
    incidence: sp.spmatrix | np.ndarray,
    weights: np.ndarray,
    *,
    items: tuple[tuple[int, ...], ...] | None = None,
    shape_names: tuple[str, ...] | None = None,
    cap: int | None = None,
    meta: Mapping[str, Any] | None = None,
    tie_break: np.ndarray | None = None,
    apart: Iterable[tuple[int, int]] = (),
) -> PackingProblem:
    """Build and presolve a `PackingProblem` from an item-by-vertex incidence matrix.

    Parameters
    ----------
    incidence : (I, N) bool array or sparse matrix
        Active vertices of each item.
    weights : (I,) float array
        Objective coefficient of each item (eq. 3a).
    items : tuple of tuple of int, optional
        Rig shape indices of each item; default one shape per item, ``((0,), (1,), ...)``.
    shape_names : tuple of str, optional
        Names of the rig's shapes; default ``s0, s1, ...``.
    cap : int, optional
        Maximum blendshapes per expression (sec. 6).
    meta : mapping, optional
        Provenance stored with the problem.
    tie_break : (I,) float array, optional
        The tie-break perturbation already included in ``weights``.
    apart : iterable of (int, int)
        Item pairs that may not share an expression (artist constraints). Each is presolved as one more
        column of the incidence in which both items are active, so the conflict sets hold it.

    Returns
    -------
    PackingProblem with its maximal conflict sets computed.
    """
    incidence = sp.csr_matrix(incidence, dtype=bool, copy=True)
    incidence.sum_duplicates()
    incidence.eliminate_zeros()  # explicit False entries are no active vertices
    weights = np.array(weights, dtype=np.float64).ravel()
    n_items = incidence.shape[0]
    if weights.shape != (n_items,):
        raise ValueError(f"weights has {weights.size} entries for {n_items} items")
    if not np.isfinite(weights).all():
        raise ValueError("weights must be finite")
    if items is None:
        items = tuple((i,) for i in range(n_items))
    if len(items) != n_items:
        raise ValueError(f"{len(items)} items for an incidence matrix of {n_items} rows")
    if shape_names is None:
        shape_names = tuple(f"s{k}" for k in range(1 + max((max(item) for item in items), default=-1)))
    if cap is not None and cap < 1:
        raise ValueError(f"cap must be a positive number of blendshapes, got {cap}")
    apart = tuple(sorted({(min(int(a), int(b)), max(int(a), int(b))) for a, b in apart}))
    if any(a == b or a < 0 or b >= n_items for a, b in apart):
        raise ValueError(f"apart pairs must be two distinct items in 0..{n_items - 1}, got {list(apart)}")
    if apart:
        columns = np.repeat(np.arange(len(apart)), 2)
        artist = sp.csr_matrix(
            (np.ones(columns.size, dtype=bool), (np.ravel(apart), columns)), shape=(n_items, len(apart))
        )
        sets, n_rows = ConflictSets.from_incidence(sp.hstack([incidence, artist], format="csr"))
        n_vertex_rows = n_rows - len(apart)
    else:
        sets, n_vertex_rows = ConflictSets.from_incidence(incidence)
    weights.flags.writeable = False
    problem = PackingProblem(
        shape_names=tuple(shape_names),
        items=tuple(tuple(int(k) for k in item) for item in items),
        weights=weights,
        incidence=incidence,
        cliques=sets.as_tuple(),
        cap=cap,
        n_vertex_rows=n_vertex_rows,
        meta=dict(meta or {}),
        tie_break=None if tie_break is None else np.asarray(tie_break, dtype=np.float64).ravel(),
        apart=apart,
    )
    return _with_structure(problem, _conflict_sets=LazyConflictSets(sets))
