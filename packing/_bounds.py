"""Bounds on the fewest expressions that cover every blendshape (beyond the paper)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

from packing._problem import PackingProblem

if TYPE_CHECKING:
    from packing._analysis import Analysis


@dataclass(frozen=True)
class ExpressionBound:
    """How many expressions are needed to use every item once.

    Attributes
    ----------
    lower : int
        No sequence covers every item with fewer expressions: the largest set of pairwise conflicting
        items (they all need different expressions), or with a cap the shapes divided by the cap,
        whichever is larger.
    upper : int
        Expressions enough to cover every item: `first_fit_colouring` of the conflict graph under the cap.
    clique : tuple of str
        Labels of the items of a largest conflict clique (the witness of ``lower``).
    """

    lower: int
    upper: int
    clique: tuple[str, ...]


def conflict_graph(problem: PackingProblem) -> sp.csr_matrix:
    """(I, I) symmetric bool CSR adjacency of the item conflict graph, without self loops.

    Two items conflict when they share an active vertex (eq. 3b) or the artist keeps them apart, which
    holds iff they share a presolved conflict set (``problem.clique_arrays``); the graph is built from
    the sets in O(sum |c|^2).
    """
    starts, members, _ = problem.clique_arrays
    sets = sp.csr_matrix(
        (np.ones(members.size, dtype=np.int32), members, starts), shape=(starts.size - 1, problem.n_items)
    )
    shared = (sets.T @ sets).tocoo()
    off_diagonal = shared.row != shared.col
    adjacency = sp.csr_matrix(
        (
            np.ones(np.count_nonzero(off_diagonal), dtype=bool),
            (shared.row[off_diagonal], shared.col[off_diagonal]),
        ),
        shape=(problem.n_items, problem.n_items),
    )
    adjacency.sort_indices()
    return adjacency


def first_fit_colouring(problem: PackingProblem, adjacency: sp.csr_matrix | None = None) -> np.ndarray:
    """Colour of every item by first fit in decreasing conflict degree, at most ``cap`` shapes a colour.

    Parameters
    ----------
    problem : PackingProblem
    adjacency : (I, I) CSR, optional
        `conflict_graph` of ``problem``, when already at hand.

    Returns
    -------
    (I,) int array of colours 0..H-1: a cover of every item by H expressions.
    """
    adjacency = conflict_graph(problem) if adjacency is None else adjacency
    degrees = np.diff(adjacency.indptr)
    counts = problem.item_shape_counts
    colour = np.full(problem.n_items, -1, dtype=np.int64)
    load: list[int] = []
    cap = np.inf if problem.cap is None else problem.cap
    for item in np.argsort(-degrees, kind="stable").tolist():
        taken = set(colour[adjacency.indices[adjacency.indptr[item] : adjacency.indptr[item + 1]]].tolist())
        chosen = next((c for c in range(len(load)) if c not in taken and load[c] + counts[item] <= cap), None)
        if chosen is None:
            chosen = len(load)
            load.append(0)
        colour[item] = chosen
        load[chosen] += int(counts[item])
    return colour


def conflict_set_bound(problem: PackingProblem) -> int:
    """The cheap lower bound on the fewest expressions: the largest presolved conflict set (its items
    pairwise conflict), or with a cap the shapes divided by the cap, whichever is larger. O(number of sets);
    `expression_lower_bound` proves the exact clique number from it."""
    if problem.n_items == 0:
        return 0
    largest = max((c.size for c in problem.cliques), default=1)
    if problem.cap is None:
        return int(largest)
    return int(max(largest, math.ceil(int(problem.item_shape_counts.sum()) / problem.cap)))


def expression_lower_bound(source: Analysis | PackingProblem) -> ExpressionBound:
    """Lower and upper bounds on the number of expressions that use every item once.

    The paper's sequence (Algorithm 1) maximises each expression in turn and is not guaranteed to
    use the fewest expressions: in a chain of conflicts a-b-c-d, packing {a, d} first leaves b and c,
    which conflict, so it takes three rounds where {a, c}, {b, d} take two. The fewest expressions is
    the chromatic number of the conflict graph (items conflict when they share an active vertex or are
    kept apart) under the cap; its largest clique bounds it from below and a greedy colouring from
    above. The exact minimum is a solver mode (`solvers.minimum_expressions`).

    Parameters
    ----------
    source : Analysis or PackingProblem
        The analysis of a rig (its problem over every item), or any packing problem.

    Returns
    -------
    ExpressionBound

    Raises
    ------
    ValueError
        If an item has more shapes than the cap (it fits in no expression).

    Notes
    -----
    The clique is exact: the largest presolved conflict set is a clique of size L, and a larger clique
    lies in the L-core of the graph (its members have at least L neighbours), whose maximal cliques are
    enumerated (`networkx.find_cliques`, Bron-Kerbosch with pivoting). On face rigs the core is a small
    part of the graph: 229 of 614 items on the ``film`` preset, about 1.5 s instead of 30-40 s of branch
    and bound over the whole graph.
    """
    problem = source if isinstance(source, PackingProblem) else source.problem
    counts = problem.item_shape_counts
    if problem.cap is not None and counts.size and counts.max() > problem.cap:
        item = int(np.argmax(counts))
        raise ValueError(
            f"item {problem.item_label(item)!r} has {counts[item]} shapes, more than the cap {problem.cap}"
        )
    adjacency = conflict_graph(problem)
    clique = _largest_clique(problem, adjacency)
    lower = max(len(clique), conflict_set_bound(problem))
    upper = int(first_fit_colouring(problem, adjacency).max(initial=-1)) + 1
    return ExpressionBound(
        lower=lower, upper=upper, clique=tuple(problem.item_label(i) for i in sorted(clique))
    )


def _largest_clique(problem: PackingProblem, adjacency: sp.csr_matrix) -> list[int]:
    """Items of a largest clique of the conflict graph, ascending (see `expression_lower_bound`)."""
    import networkx as nx  # only here: importing packing stays cheap

    witness = max(problem.cliques, key=len, default=np.zeros(0, dtype=np.int64)).tolist()
    core = nx.k_core(nx.from_scipy_sparse_array(adjacency), len(witness))
    larger = max(nx.find_cliques(core), key=len, default=[]) if core.number_of_nodes() else []
    return sorted(larger if len(larger) > len(witness) else witness)
