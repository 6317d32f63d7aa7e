"""The rig analysis done once per rig (secs. 4.1-4.4) and the packing problem of each expression."""

from __future__ import annotations

import hashlib
import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp

from packing._binary import active_entries
from packing._importance import (
    ImportanceTerms,
    importance_terms,
    require_nonempty,
    target_neutral_of,
    used_mask,
    warn_missing_target,
)
from packing._params import PackingParams, params_from
from packing._problem import PackingProblem, problem_from_incidence, with_meta
from packing._symmetry import SymmetryResult, detect_pairs, resolve_constraints
from registry import HarnessError
from rigs import Rig

#: Scale of the tie-break perturbation (see `tie_break_perturbation`).
TIE_BREAK_SCALE = 1e-5


@dataclass(frozen=True, eq=False)
class Analysis:
    """Everything about a rig that Algorithm 1 computes once, before its first expression.

    Binary blendshapes (eq. 2), the importance terms that do not change between expressions
    (eqs. 5-7), the symmetry pairs (eqs. 9-12), the items (shapes, and pairs merged into one item)
    with their vertex incidence, and the presolved problem over all items. Each expression's
    problem is derived from it by `problem_for`, or from the previous expression's problem by
    `next_problem`, without visiting the vertices again.

    Attributes
    ----------
    rig : Rig
    params : PackingParams
    target : (N, 3) array or None
        The target neutral of eq. 6, if given.
    active : (K, N) CSR bool matrix with sorted indices
        Binary blendshapes (eq. 2); `masks` is the dense form.
    empty : (K,) bool array
        Shapes with no displacement above the noise floor (excluded from packing).
    terms : ImportanceTerms
        ``lambda_Dis``, ``lambda_TD`` and the cosines of eq. 8.
    symmetry : SymmetryResult
        Pairs and the evidence for them.
    problem : PackingProblem
        The presolved problem over every item, weighted for the first expression.
    item_shapes : (I, K) sparse CSR matrix
        Which shapes form each item (1 or 2 per row).
    timings : dict
        Seconds spent in each step (``binary``, ``importance``, ``symmetry``, ``items``, ``presolve``,
        ``total``).
    """

    rig: Rig
    params: PackingParams
    target: np.ndarray | None
    active: sp.csr_matrix
    empty: np.ndarray
    terms: ImportanceTerms
    symmetry: SymmetryResult
    problem: PackingProblem
    item_shapes: sp.csr_matrix
    timings: dict[str, float] = field(default_factory=dict)

    def __repr__(self) -> str:
        problem, source = self.problem, self.rig.provenance.label
        return (
            f"Analysis(rig={source!r}, K={self.rig.n_shapes}, items={problem.n_items}, "
            f"pairs={len(self.symmetry.pairs)}, empty={int(self.empty.sum())}, "
            f"rows={problem.n_vertex_rows}->{len(problem.cliques)}, "
            f"total={self.timings.get('total', 0.0):.3f}s)"
        )

    # -- reports -----------------------------------------------------------------------------------------
    @property
    def masks(self) -> np.ndarray:
        """(K, N) bool array: the binary blendshapes (eq. 2), made dense on each read from `active`."""
        return self.active.toarray()

    @property
    def empty_names(self) -> tuple[str, ...]:
        """Names of the empty shapes, excluded from packing."""
        return tuple(self.rig.names[k] for k in np.flatnonzero(self.empty))

    @property
    def pairs(self) -> tuple[tuple[str, str], ...]:
        """Symmetry pairs by name: mirror pairs, then motion pairs."""
        return tuple((self.rig.names[a], self.rig.names[b]) for a, b in self.symmetry.pairs)

    @property
    def self_symmetric(self) -> tuple[str, ...]:
        """Names of the self-symmetric shapes."""
        return tuple(self.rig.names[k] for k in self.symmetry.self_symmetric)

    @property
    def packable(self) -> np.ndarray:
        """(K,) bool array: shapes that can be packed (the non-empty ones)."""
        return ~self.empty

    @property
    def notes(self) -> tuple[str, ...]:
        """What the analysis skipped or could not do, in words."""
        notes = list(self.symmetry.notes)
        if self.empty.any():
            notes.append(f"{int(self.empty.sum())} empty blendshapes excluded: {', '.join(self.empty_names)}")
        if self.params.importance and self.target is None and self.params.alpha < 1:
            notes.append("no target neutral: triangle distortion (eqs. 6-7) is 0")
        return tuple(notes)

    # -- per-expression weights and problems ------------------------------------------------------------
    def shape_weights(self, used: Iterable[str | int] = ()) -> np.ndarray:
        """(K,) importance of each shape before the next expression (eq. 4), or 1 without importance.

        ``used`` (names) are the shapes already in reference expressions, for the uniqueness term.
        Empty shapes weigh 0.
        """
        return _shape_weights(self.params, self.terms, self.packable, used_mask(self.rig, used))

    def item_weights(self, used: Iterable[str | int] = ()) -> np.ndarray:
        """(I,) objective coefficients: shape weights summed per item, plus the tie-break."""
        return self.item_shapes @ self.shape_weights(used) + self.problem.tie_break

    def problem_for(self, used: Iterable[str] = (), exclude: Iterable[str] = ()) -> PackingProblem:
        """The packing problem of the next expression (Algorithm 1, one iteration).

        Parameters
        ----------
        used : iterable of str
            Shapes already in reference expressions: their items are removed, and the uniqueness
            term (eq. 8) is recomputed from them when ``beta > 0``.
        exclude : iterable of str
            Shapes rejected for this expression only (artist refinement, sec. 4.5.3); an item with a
            rejected shape is removed whole.

        Returns
        -------
        PackingProblem over the remaining items, renumbered; ``meta["item_index"]`` maps its items
        to the items of `problem`.
        """
        used = tuple(used)
        gone = used_mask(self.rig, used) | used_mask(self.rig, exclude)
        keep = np.flatnonzero(self.item_shapes @ gone.astype(np.float64) == 0)
        problem = self.problem
        if self._reweights(used):
            problem = problem.reweighted(self.item_weights(used))
        if keep.size != problem.n_items:
            problem = problem.restrict(keep)
        return with_meta(problem, item_index=keep, used=len(used), excluded=tuple(exclude))

    def next_problem(
        self, problem: PackingProblem, chosen: Iterable[int], used: Iterable[str] = ()
    ) -> PackingProblem:
        """The problem of the expression after ``problem``, once its items ``chosen`` are used.

        One step of Algorithm 1 on the shrinking problem (docs/architecture.md): the chosen items are
        dropped from ``problem``'s presolved conflict sets (`PackingProblem.restrict`), no vertex is visited,
        and the weights are recomputed only when the uniqueness term (eq. 8) changes them
        (``beta > 0``).

        Parameters
        ----------
        problem : PackingProblem
            A problem of this analysis without exclusions: from `problem_for` or `next_problem`.
        chosen : iterable of int
            Items of ``problem`` used by its expression.
        used : iterable of str
            Every shape used so far, those of ``chosen`` included.

        Returns
        -------
        PackingProblem equal to ``problem_for(used)`` (same items, weights, conflict sets and rows).

        Raises
        ------
        ValueError
            For a problem that does not come from this analysis or that excludes shapes, or items
            outside it.
        """
        if "item_index" not in problem.meta or problem.meta.get("excluded"):
            raise ValueError(
                "next_problem: need a problem of this analysis without excluded shapes "
                "(from problem_for() or next_problem())"
            )
        used = tuple(used)
        chosen = np.fromiter(chosen, dtype=np.int64)
        if chosen.size and (chosen.min() < 0 or chosen.max() >= problem.n_items):
            raise ValueError(
                f"next_problem: chosen items must be in 0..{problem.n_items - 1}, got {chosen.tolist()}"
            )
        kept = np.ones(problem.n_items, dtype=bool)
        kept[chosen] = False
        following = problem.restrict(np.flatnonzero(kept), meta={"used": len(used)})
        if self._reweights(used):
            following = following.reweighted(self.item_weights(used)[following.meta["item_index"]])
        return following

    def item_label(self, item: int) -> str:
        """Label of an item of `problem`: its shape name, or ``a+b`` for a pair."""
        return self.problem.item_label(item)

    def _reweights(self, used: tuple[str | int, ...]) -> bool:
        """Whether the weights after the shapes ``used`` differ from the first expression's (eq. 8)."""
        return self.params.beta > 0 and self.params.importance and bool(used)


def analyse(rig: Rig, target_neutral: Rig | np.ndarray | None = None, **params: Any) -> Analysis:
    """Analyse a rig for expression packing (Carrigan et al. 2020, Algorithm 1 before its loop).

    Parameters
    ----------
    rig : Rig
        The template rig A.
    target_neutral : (N, 3) array or Rig, optional
        Neutral of the target character B, for triangle distortion (eqs. 6-7).
    **params
        `PackingParams` fields: ``mu``, ``alpha``, ``beta``, ``importance``, ``distortion``, ``symmetry``,
        ``shape_symmetry``, ``motion_symmetry``, ``max_per_expression``, ... (or ``params=`` a
        `PackingParams`).

    Returns
    -------
    Analysis

    Raises
    ------
    ValueError
        For parameters out of range or unknown, a target with other topology, region names the rig
        does not have, or a rig whose every shape is empty.

    Notes
    -----
    One pass over the (K, N, 3) deltas for the displacement lengths, the masks and the active
    displacements (`packing._binary.active_entries`), then sparse work on the active entries only:
    sparse products for the triangle terms and the eq. 9 sums, a KD-tree for the mirror map
    (O(N log N)), and displacement vectors read only for the pairs that eq. 10 cannot rule out from
    the sums. The paper's reference code needed ~190 s on a 10k-vertex,
    150-shape rig; the generated paper-sized rigs take well under a second here.
    """
    settings = params_from(params.pop("params", None), **params)
    clock = time.perf_counter()
    timings: dict[str, float] = {}

    def lap(step: str) -> None:
        nonlocal clock
        now = time.perf_counter()
        timings[step] = now - clock
        clock = now

    target = target_neutral_of(rig, target_neutral)
    norms, empty, active, moved = active_entries(
        rig.deltas, settings.mu, settings.noise_floor, rig.diagonal(), gather=settings.use_shape_symmetry
    )
    require_nonempty(rig, empty)
    lap("binary")
    if settings.importance and target is None:
        warn_missing_target(settings.alpha)
    terms = importance_terms(rig, active, norms, target if settings.importance else None, settings.distortion)
    lap("importance")
    together, apart = resolve_constraints(rig, settings, empty)
    symmetry = detect_pairs(rig, norms, active, empty, settings, together, apart, moved)
    del moved  # (the symmetry step's only use)
    lap("symmetry")
    if settings.max_per_expression == 1 and symmetry.pairs:
        a, b = symmetry.pairs[0]
        raise HarnessError(
            f"a cap of 1 shape per expression (max_per_expression=1, --cap 1) cannot hold the symmetry pair "
            f"{rig.names[a]}+{rig.names[b]} ({len(symmetry.pairs)} pairs found): allow 2 or more, or turn "
            "symmetry off (symmetry=False, --no-symmetry)"
        )
    item_shapes = _item_matrix(rig.n_shapes, empty, symmetry.pairs)
    bounds = zip(item_shapes.indptr[:-1], item_shapes.indptr[1:], strict=True)
    items = tuple(tuple(int(k) for k in item_shapes.indices[a:b]) for a, b in bounds)
    incidence = _item_incidence(item_shapes, active)
    labels = ["+".join(rig.names[k] for k in item) for item in items]
    tie_break = tie_break_perturbation(labels)
    lap("items")
    weights = (
        item_shapes @ _shape_weights(settings, terms, ~empty, np.zeros(rig.n_shapes, dtype=bool)) + tie_break
    )
    problem = problem_from_incidence(
        incidence,
        weights,
        items=items,
        shape_names=rig.names,
        cap=settings.max_per_expression,
        meta={"rig": rig.provenance.label, "params": settings.as_dict()},
        tie_break=tie_break,
        apart=_item_pairs(item_shapes, apart),
    )
    lap("presolve")
    timings["total"] = sum(timings.values())
    return Analysis(rig, settings, target, active, empty, terms, symmetry, problem, item_shapes, timings)


def build_problem(
    rig: Rig, target_neutral: Rig | np.ndarray | None = None, *, exclude: Iterable[str] = (), **params: Any
) -> PackingProblem:
    """The packing problem of a rig's first expression (Carrigan et al. 2020, eq. 3 and sec. 6).

    Items are the non-empty blendshapes, with each symmetry pair merged into one item whose active
    vertex set is the union of both shapes' and whose weight is the sum of both importances
    (eq. 3d, sec. 4.4). Weights carry the tie-break of `tie_break_perturbation`. The conflict rows are
    presolved to the maximal conflict sets; ``n_vertex_rows`` and ``len(cliques)`` report the rows
    before and after.

    Parameters
    ----------
    rig : Rig
    target_neutral : (N, 3) array or Rig, optional
        Neutral of the target character, for triangle distortion (eqs. 6-7).
    exclude : iterable of str
        Shapes rejected for this expression (sec. 4.5.3); an item containing one is left out.
    **params
        `PackingParams` fields (``mu``, ``alpha``, ``beta``, ``importance``, ``symmetry``,
        ``max_per_expression``, ...).

    Returns
    -------
    PackingProblem

    Examples
    --------
    >>> problem = build_problem(rig, mu=0.3, max_per_expression=12)  # doctest: +SKIP
    >>> problem.n_vertex_rows, len(problem.cliques)  # doctest: +SKIP
    (4870, 212)
    """
    return analyse(rig, target_neutral, **params).problem_for(exclude=exclude)


def tie_break_perturbation(labels: list[str], scale: float = TIE_BREAK_SCALE) -> np.ndarray:
    """Deterministic perturbation that makes the optimum of eq. 3 unique.

    Item i gets ``eps_i = scale * (r_i + 1 + frac(sqrt(p_{r_i})) / 4) / (I + 1)`` where ``r_i`` is the
    rank of its label's BLAKE2b digest among the I item labels (so it depends on names, not on the
    order of the shapes) and ``p_r`` is the r-th prime.

    Guarantees, for two feasible sets of items S and T:

    * **Real differences are kept.** ``eps_i < scale``, so the perturbation changes the order of S and
      T only when their unperturbed weights differ by less than ``scale * max(|S - T|, |T - S|)``
      (1e-5 per differing item; importance terms are normalised to [0, 1]). Without importance the
      weights are integers and the perturbations sum to less than 1 (for fewer than 10^5 items), so
      the number of shapes chosen is never changed.
    * **No exact ties.** Square roots of distinct primes and 1 are linearly independent over the
      rationals, so distinct S and T always have distinct perturbations (in exact arithmetic): the
      optimum is unique.
    * **Ties are broken visibly.** Exchanging up to three items for as many others of a different
      rank sum changes the objective by at least ``scale / (4 (I + 1))`` (>= 9.4e-9 for I <= 265), so
      exact backends run with an absolute optimality gap of 1e-9 (and no relative gap) all return
      the same set.

    Parameters
    ----------
    labels : list of str
        Item labels (shape names, ``a+b`` for pairs), all distinct.
    scale : float

    Returns
    -------
    (I,) float array in (0, scale).
    """
    digests = [hashlib.blake2b(label.encode(), digest_size=8).digest() for label in labels]
    rank = np.empty(len(labels), dtype=np.int64)
    rank[sorted(range(len(labels)), key=lambda i: (digests[i], labels[i]))] = np.arange(len(labels))
    roots = np.sqrt(_primes(len(labels)).astype(np.float64))
    jitter = (roots - np.floor(roots))[rank]
    return scale * (rank + 1 + jitter / 4) / (len(labels) + 1)


def _primes(count: int) -> np.ndarray:
    """The first ``count`` primes (sieve of Eratosthenes)."""
    limit = max(16, int(count * (np.log(count + 2) + np.log(np.log(count + 3)) + 2)))
    sieve = np.ones(limit + 1, dtype=bool)
    sieve[:2] = False
    for p in range(2, int(limit**0.5) + 1):
        if sieve[p]:
            sieve[p * p :: p] = False
    return np.flatnonzero(sieve)[:count]


def _shape_weights(
    params: PackingParams, terms: ImportanceTerms, packable: np.ndarray, used: np.ndarray
) -> np.ndarray:
    """Eq. 4 for the packable shapes given the used ones; all 1 in the "no importance" mode."""
    if not params.importance:
        return packable.astype(np.float64)
    return terms.combine(params.alpha, params.beta, used, packable & ~used) * packable


def _item_pairs(item_shapes: sp.csr_matrix, shape_pairs: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """The items holding each pair of shapes (pairs with an empty shape, which is in no item, left out)."""
    item_of = np.full(item_shapes.shape[1], -1, dtype=np.int64)
    coo = item_shapes.tocoo()
    item_of[coo.col] = coo.row
    return [(int(item_of[a]), int(item_of[b])) for a, b in shape_pairs if item_of[a] >= 0 and item_of[b] >= 0]


def _item_incidence(item_shapes: sp.csr_matrix, active: sp.csr_matrix) -> sp.csr_matrix:
    """(I, N) CSR bool matrix with sorted indices: the active vertices of each item, the union of its shapes'
    (eq. 3d). Each item's row is the sum of the rows of its first and its last shape (one shape's row with
    itself for a single shape): sorted rows merged, with no product over the shapes."""
    first = item_shapes.indices[item_shapes.indptr[:-1]]
    last = item_shapes.indices[item_shapes.indptr[1:] - 1]
    return active[first] + active[last]


def _item_matrix(n_shapes: int, empty: np.ndarray, pairs: tuple[tuple[int, int], ...]) -> sp.csr_matrix:
    """(I, K) 0/1 matrix of the shapes forming each item, items in order of their first shape."""
    partner = np.full(n_shapes, -1, dtype=np.int64)
    for a, b in pairs:
        partner[a], partner[b] = b, a
    first = np.flatnonzero(~empty & ((partner < 0) | (np.arange(n_shapes) < partner)))
    second = partner[first]
    rows = np.concatenate([np.arange(first.size), np.flatnonzero(second >= 0)])
    cols = np.concatenate([first, second[second >= 0]])
    matrix = sp.csr_matrix((np.ones(rows.size), (rows, cols)), shape=(first.size, n_shapes))
    matrix.sort_indices()
    return matrix
