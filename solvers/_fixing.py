"""Reduced-cost fixing: items that no optimal packing can hold, proved by the LP bound and a good packing.

The linear relaxation of the clique model (eq. 3 with the rows of `solvers._cliques`) is tight on film-sized
rigs: its bound is within a few per cent of the optimum. Any row duals ``y >= 0`` give an upper bound on
every packing ``x`` of ``A x <= u``, ``0 <= x <= 1`` (Lagrangian duality)::

    w.x  <=  u.y + sum_i max(0, r_i),      r = w - A^T y   (the reduced costs)

and on every packing that holds item j, ``u.y + sum_i max(0, r_i) + min(0, r_j)``. When that second bound is
below the objective of a known packing, no packing holding j is optimal, and j can be left out: the optimal
packings (and the optimum) stay exactly the same. The bound is evaluated here in floating point from the
duals, whatever their accuracy, so it is a true bound for any ``y`` the LP solver returns; a margin far
above the rounding of the sums keeps the comparison strict. This is the reduced-cost fixing of MIP solvers
(Nemhauser and Wolsey 1988, "Integer and combinatorial optimization", sec. II.5.1), the LP solved once, before
the backend builds its model, with the better of the start packing (Algorithm 2's) and the LP's rounding.

That packing is a few per cent short of the optimum, and the fixing is much stronger at the optimum (on the
largest problems of a 2,000-shape sequence it leaves out half of the kernel's items instead of a fifth).
`solve_with_fixing` therefore fixes at a *target* above the packing and solves what is left: when that
optimum reaches the target, every packing holding a left-out item is below it, so it is the optimum of the
whole model; when it does not, it is a packing, usually far better than the known one, and a last solve
fixes at the best objective found, which is exact as above.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from packing import Termination, pack_bit_rows
from solvers._base import Result
from solvers._cliques import kernel_neighbourhoods
from solvers._model import CliqueModel
from solvers._reduce import reduce_graph

if TYPE_CHECKING:
    import scipy.sparse as sp

#: Kernels with fewer items are solved as they are: the backends prove them faster than the LP is solved.
FIXING_MIN_ITEMS = 100
#: The fixings' targets before the last one: these fractions of the way from the best packing found so far
#: to the LP bound. The LP bound itself (1.0) leaves only the items of nonnegative reduced cost, a model
#: solved in milliseconds whose optimum is a far better packing than local search finds; fixing at that
#: optimum then proves the whole model's in one more solve. Intermediate targets (0.5, 0.7, 0.85) were
#: measured slower on film-sized sequences, HiGHS by 20-50%.
TARGET_FRACTIONS = (1.0,)
#: A bound must fall below the packing's objective by this much (relative to the total weight) to fix an
#: item; it dwarfs the floating-point error of the sums (about 1e-15 of the total weight).
FIXING_MARGIN = 1e-9
#: LP values above this are rounded up: at most one item of a clique row can exceed it.
ROUNDING_THRESHOLD = 0.75


@dataclass(frozen=True)
class ReducedCosts:
    """What the LP relaxation of a model proves about each item.

    Attributes
    ----------
    model : CliqueModel
    with_item : (I,) float array
        An upper bound on every packing holding item i (``u.y + sum max(0, r) + min(0, r_i)``).
    bound : float
        An upper bound on every packing (the LP bound from the duals).
    packing : tuple of int
        The best packing found, as items of ``model``, ascending.
    margin : float
        How far below a level a bound must be to leave the item out (`FIXING_MARGIN` of the total weight).
    closed : (I, W) uint64 array
        Closed neighbourhoods of the model's items as bit rows (`packing.PackingProblem.conflict_bits`
        order), from which the kept items' dominations are read (`_solve_kept`).
    """

    model: CliqueModel
    with_item: np.ndarray
    bound: float
    packing: tuple[int, ...]
    margin: float
    closed: np.ndarray

    def objective(self, items: Sequence[int]) -> float:
        """Eq. 3a of ``items`` of the model."""
        return float(self.model.weights[np.asarray(items, dtype=np.int64)].sum())

    def kept(self, level: float) -> np.ndarray:
        """Items of the model some packing of objective ``level`` or more may hold, ascending."""
        return np.flatnonzero(self.with_item >= level - self.margin)


def reduced_costs(
    model: CliqueModel, start: Sequence[int], closed: np.ndarray | None = None
) -> ReducedCosts | None:
    """The LP relaxation's bounds per item and the best packing from ``start`` and the LP's rounding.

    Parameters
    ----------
    model : CliqueModel
    start : sequence of int
        A feasible packing of ``model``.
    closed : (I, W) uint64 array, optional
        Closed neighbourhoods of the model's items as bit rows (items sharing a row, each item with
        itself), when the caller has them; default from `CliqueModel.conflict_graph`.

    Returns
    -------
    ReducedCosts or None
        None when the model is too small to be worth it (`FIXING_MIN_ITEMS`) or the LP solver fails.
    """
    if model.n_items < FIXING_MIN_ITEMS:
        return None
    weights, matrix, upper = model.weights, model.matrix(), model.upper()
    relaxation = _relaxation(matrix, upper, weights)
    if relaxation is None:
        return None
    values, duals = relaxation
    reduced = weights - matrix.T @ duals
    bound = float(upper @ duals + np.maximum(reduced, 0.0).sum())
    margin = FIXING_MARGIN * max(1.0, float(np.abs(weights).sum()))
    if closed is None:
        neighbours = model.conflict_graph().toarray()
        np.fill_diagonal(neighbours, True)
        closed = pack_bit_rows(neighbours)
    packing = _best_packing(model, values, start)
    return ReducedCosts(model, bound + np.minimum(reduced, 0.0), bound, packing, margin, closed)


def _relaxation(
    matrix: sp.csr_matrix, upper: np.ndarray, weights: np.ndarray
) -> tuple[np.ndarray, np.ndarray] | None:
    """Values and nonnegative row duals of ``max w.x, matrix x <= upper, 0 <= x <= 1`` by HiGHS's dual
    simplex through highspy's arrays, or None when it does not end optimal or highspy cannot be imported
    (the model is then solved without fixing: the same optimum).

    HiGHS's presolve stays off: the rows are maximal cliques of a kernel without dominated items, so it
    finds nothing to remove, and skipping it takes a third off the LPs of a film-sized sequence (the same
    optimum; any duals give a true bound, see the module notes). highspy rather than SciPy's ``linprog``
    (the same dual simplex): ``linprog``'s checks and conversions took a fifth of these LPs' time (the 75
    of a 2,000-shape film sequence: 0.63 -> 0.50 CPU s)."""
    try:
        import highspy
    except ImportError:
        return None
    from solvers._highs_model import configured_highs, pass_model

    highs = configured_highs(highspy, None, 0, presolve="off", solver="simplex", simplex_strategy=1)
    n_rows, n_items = matrix.shape
    pass_model(
        highspy, highs, matrix, np.full(n_rows, -np.inf), upper, -weights,
        np.zeros(n_items), np.ones(n_items), integral=False,
    )  # fmt: skip
    highs.run()
    if highs.getModelStatus() != highspy.HighsModelStatus.kOptimal:
        return None
    solution = highs.getSolution()
    # (minimising -w: the duals of the <= rows are <= 0, those of max w.x their negation)
    return np.asarray(solution.col_value), np.maximum(-np.asarray(solution.row_dual), 0.0)


def solve_with_fixing(costs: ReducedCosts, solve: Callable[[CliqueModel, tuple[int, ...]], Result]) -> Result:
    """The optimum of ``costs.model`` by ``solve(model, start)`` on the model without the items fixed out.

    At each target level of `TARGET_FRACTIONS` in turn, then at the best objective found (see the module
    notes). Items, bound and times of the answer are the whole model's.

    Parameters
    ----------
    costs : ReducedCosts
    solve : callable
        The backend on a model and a start packing of it (items of that model).

    Returns
    -------
    Result
        Items of ``costs.model``; the bound covers the packings holding a left-out item too.
    """
    packing, value = costs.packing, costs.objective(costs.packing)
    build_time: float | None = 0.0
    solve_time: float | None = 0.0
    for fraction in (*TARGET_FRACTIONS, None):
        level = value if fraction is None else value + fraction * (costs.bound - value)
        result = _solve_kept(costs, costs.kept(level), packing, solve)
        build_time = _total(build_time, result.build_time)
        solve_time = _total(solve_time, result.solve_time)
        if result.termination is not Termination.OPTIMAL:
            break
        found = costs.objective(result.items)
        if found >= level:  # every packing holding a left-out item is below ``level``
            break
        if found > value:
            packing, value = tuple(result.items), found
    return replace(result, build_time=build_time, solve_time=solve_time)


def _solve_kept(
    costs: ReducedCosts,
    kept: np.ndarray,
    packing: Sequence[int],
    solve: Callable[[CliqueModel, tuple[int, ...]], Result],
) -> Result:
    """``solve`` on the model restricted to ``kept``, without the items that other kept items dominate,
    started from the rest of ``packing``; answered as items of the whole model, its bound raised to cover
    the packings holding an item left out.

    The items left out by their bounds no longer crowd the neighbourhoods of the kept ones, so that some
    kept items are dominated now (`solvers._reduce.reduce_graph`: a fifth of the search on a 2,000-shape
    film sequence). No optimal packing of the restricted model holds one, and every packing holding one is
    matched by a better one without it, so the restricted optimum and the backend's bound stay those of
    the restricted model."""
    restricted = kernel_neighbourhoods(costs.closed, kept, costs.model.n_items)
    counts = costs.model.shape_counts[kept]
    cap_binds = costs.model.cap is not None and costs.model.cap < int(counts.sum())
    remaining, isolated = reduce_graph(costs.model.weights[kept], counts, restricted, cap_binds)
    solved = kept[np.union1d(remaining, isolated)]  # (isolated items are left to the backend)
    position = np.full(costs.model.n_items, -1, dtype=np.int64)
    position[solved] = np.arange(solved.size)
    start = position[np.asarray(packing, dtype=np.int64)]
    result = solve(costs.model.restricted(solved), tuple(start[start >= 0].tolist()))
    items = tuple(solved[np.asarray(result.items, dtype=np.int64)].tolist())
    left_out = np.ones(costs.model.n_items, dtype=bool)
    left_out[kept] = False
    bound = result.bound
    if bound is not None and left_out.any():
        bound = max(bound, float(costs.with_item[left_out].max()))
    return replace(result, items=items, bound=bound)


def _total(first: float | None, second: float | None) -> float | None:
    return None if first is None or second is None else first + second


def _best_packing(model: CliqueModel, relaxed: np.ndarray, start: Sequence[int]) -> tuple[int, ...]:
    """The better of ``start`` and the LP's rounding (when it respects the cap).

    Not improved by local search: the first fixed solve, at the LP bound, finds a far better packing in
    milliseconds (see the module notes), and the swaps of `solvers.local_search.locally_optimal` cost more
    than the backend gained from the better start (a tenth of a 1,000-shape film sequence, measured)."""
    rounded = np.flatnonzero(relaxed > ROUNDING_THRESHOLD)
    packings = [tuple(start)]
    if model.cap is None or model.shape_counts[rounded].sum() <= model.cap:
        packings.append(tuple(rounded.tolist()))
    return max(packings, key=lambda items: float(model.weights[list(items)].sum()))
