"""Bounds on the fewest expressions that cover every blendshape (beyond the paper)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import networkx as nx
import numpy as np
import scipy.sparse as sp

from packing._analysis import Analysis
from packing._problem import PackingProblem


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
        Expressions enough to cover every item: a greedy colouring of the conflict graph, each colour
        class split into parts that respect the cap.
    clique : tuple of str
        Labels of the items of a largest conflict clique (the witness of ``lower``).
    """

    lower: int
    upper: int
    clique: tuple[str, ...]


def conflict_graph(problem: PackingProblem) -> nx.Graph:
    """Items as nodes, an edge wherever two items share an active vertex."""
    incidence = sp.csr_matrix(problem.incidence, dtype=np.float64)
    shared = sp.triu(incidence @ incidence.T, k=1).tocoo()
    graph = nx.Graph()
    graph.add_nodes_from(range(problem.n_items))
    graph.add_edges_from(zip(shared.row.tolist(), shared.col.tolist(), strict=True))
    return graph


def expression_lower_bound(source: Analysis | PackingProblem) -> ExpressionBound:
    """Lower and upper bounds on the number of expressions that use every item once.

    The paper's sequence (Algorithm 1) maximises each expression in turn and is not guaranteed to
    use the fewest expressions: in a chain of conflicts a-b-c-d, packing {a, d} first leaves b and c,
    which conflict, so it takes three rounds where {a, c}, {b, d} take two. The fewest expressions is
    the chromatic number of the conflict graph (items conflict when they share an active vertex)
    under the cap; its largest clique bounds it from below and a greedy colouring from above. The
    exact minimum is a solver mode.

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
    The clique is exact (`networkx.max_weight_clique`, branch and bound); conflict graphs of face
    rigs are sparse outside the mouth and eyes, where a few dozen shapes overlap.
    """
    problem = source.problem if isinstance(source, Analysis) else source
    counts = problem.item_shape_counts
    if problem.cap is not None and counts.size and counts.max() > problem.cap:
        item = int(np.argmax(counts))
        raise ValueError(
            f"item {problem.item_label(item)!r} has {counts[item]} shapes, more than the cap {problem.cap}"
        )
    graph = conflict_graph(problem)
    clique, _ = nx.max_weight_clique(graph, weight=None) if problem.n_items else ([], 0)
    lower = len(clique)
    colours = nx.greedy_color(graph, strategy="largest_first")
    classes: dict[int, list[int]] = {}
    for item, colour in colours.items():
        classes.setdefault(colour, []).append(item)
    if problem.cap is None:
        upper = len(classes)
    else:
        lower = max(lower, math.ceil(int(counts.sum()) / problem.cap))
        upper = sum(
            _first_fit(sorted(counts[members].tolist(), reverse=True), problem.cap)
            for members in classes.values()
        )
    return ExpressionBound(
        lower=lower, upper=upper, clique=tuple(problem.item_label(i) for i in sorted(clique))
    )


def _first_fit(sizes: list[int], capacity: int) -> int:
    """Bins used by first-fit packing of item sizes (items run over shapes, not vertices)."""
    bins: list[int] = []
    for size in sizes:
        for b, load in enumerate(bins):
            if load + size <= capacity:
                bins[b] += size
                break
        else:
            bins.append(size)
    return len(bins)
