"""The packing problem handed to solvers: items, weights, presolved conflict sets, cap (eq. 3, sec. 6)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import scipy.sparse as sp

from packing._presolve import maximal_conflict_sets, restrict_conflict_sets


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
    """

    shape_names: tuple[str, ...]
    items: tuple[tuple[int, ...], ...]
    weights: np.ndarray
    incidence: sp.csr_matrix
    cliques: tuple[np.ndarray, ...]
    cap: int | None = None
    n_vertex_rows: int = 0
    meta: Mapping[str, Any] = field(default_factory=dict)
    tie_break: np.ndarray | None = None

    @property
    def n_items(self) -> int:
        """I, the number of items."""
        return len(self.items)

    @property
    def item_shape_counts(self) -> np.ndarray:
        """(I,) int array: blendshapes in each item (1, or 2 for a pair); the cap counts these."""
        return np.fromiter((len(item) for item in self.items), dtype=np.int64, count=len(self.items))

    @property
    def item_active_counts(self) -> np.ndarray:
        """(I,) int array: active vertices of each item, ``|b_k|`` in Algorithm 2."""
        return np.asarray(self.incidence.sum(axis=1)).ravel().astype(np.int64)

    def item_label(self, item: int) -> str:
        """Human-readable label: the shape name, or ``a+b`` for a pair."""
        return "+".join(self.shape_names[k] for k in self.items[item])

    def shapes_of(self, chosen: Iterable[int]) -> tuple[str, ...]:
        """Names of the blendshapes in the chosen items, in item order."""
        return tuple(self.shape_names[k] for i in sorted(chosen) for k in self.items[i])

    def objective(self, chosen: Iterable[int]) -> float:
        """Objective value (eq. 3a) of a set of items."""
        return float(self.weights[np.fromiter(chosen, dtype=np.int64)].sum())

    @property
    def n_clique_rows(self) -> int:
        """Number of conflict rows after presolve (the maximal conflict sets)."""
        return len(self.cliques)

    def unperturbed_objective(self, chosen: Iterable[int]) -> float:
        """Objective of a set of items without the tie-break perturbation (the importance sum)."""
        index = np.fromiter(chosen, dtype=np.int64)
        perturbation = 0.0 if self.tie_break is None else float(self.tie_break[index].sum())
        return float(self.weights[index].sum()) - perturbation

    def restrict(self, keep: Iterable[int]) -> PackingProblem:
        """The same problem over a subset of its items (renumbered in ascending order), presolved anew.

        Used by the expression sequence (Algorithm 1 removes the items already used) and by artist
        refinement (sec. 4.5.3 excludes rejected items from the current expression). The new conflict
        sets are derived from this problem's maximal sets, not from the vertices
        (`packing._presolve.restrict_conflict_sets`).
        """
        keep_index = np.unique(np.fromiter(keep, dtype=np.int64))
        if keep_index.size and (keep_index[0] < 0 or keep_index[-1] >= self.n_items):
            raise ValueError(
                f"restrict: item indices must be in 0..{self.n_items - 1}, got {keep_index.tolist()}"
            )
        incidence = self.incidence[keep_index]
        weights = self.weights[keep_index]
        weights.flags.writeable = False
        return replace(
            self,
            items=tuple(self.items[i] for i in keep_index),
            weights=weights,
            incidence=incidence,
            cliques=restrict_conflict_sets(self.cliques, keep_index, self.n_items),
            n_vertex_rows=int(np.count_nonzero(np.bincount(incidence.indices, minlength=incidence.shape[1]))),
            meta=_restricted_meta(self.meta, keep_index),
            tie_break=None if self.tie_break is None else self.tie_break[keep_index],
        )

    def reweighted(self, weights: np.ndarray, tie_break: np.ndarray | None = None) -> PackingProblem:
        """The same items and conflict sets with new objective coefficients (no new presolve)."""
        weights = np.array(weights, dtype=np.float64).ravel()
        if weights.shape != (self.n_items,) or not np.isfinite(weights).all():
            raise ValueError(f"reweighted: need {self.n_items} finite weights, got shape {weights.shape}")
        weights.flags.writeable = False
        return replace(
            self, weights=weights, tie_break=tie_break if tie_break is not None else self.tie_break
        )


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

    Returns
    -------
    PackingProblem with its maximal conflict sets computed.
    """
    incidence = sp.csr_matrix(incidence, dtype=bool)
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
    cliques, n_vertex_rows = maximal_conflict_sets(incidence)
    weights.flags.writeable = False
    return PackingProblem(
        shape_names=tuple(shape_names),
        items=tuple(tuple(int(k) for k in item) for item in items),
        weights=weights,
        incidence=incidence,
        cliques=cliques,
        cap=cap,
        n_vertex_rows=n_vertex_rows,
        meta=dict(meta or {}),
        tie_break=None if tie_break is None else np.asarray(tie_break, dtype=np.float64).ravel(),
    )
