"""Packing-like expression weights for transfer tests and benchmarks, without running a solver."""

from __future__ import annotations

import numpy as np

from rigs import Rig


def packing_weights(rig: Rig, n_expressions: int | None = None, mu: float = 0.3) -> np.ndarray:
    """A packing-like sequence: first-fit greedy of shapes with disjoint active vertices (eq. 2).

    Largest shapes first; when every shape is placed and more expressions are wanted, further passes
    pack the shapes again (the second pass of Carrigan et al. 2020, sec. 6).

    Parameters
    ----------
    rig : Rig
        The template whose shapes are packed.
    n_expressions : int, optional
        Expressions to make; by default as many as one pass over the shapes takes.
    mu : float
        A vertex is active in a shape when it moves at least ``mu`` times the shape's largest displacement.

    Returns
    -------
    (J, K) array of 0/1 weights.
    """
    length = np.linalg.norm(rig.deltas, axis=-1)
    active = length >= mu * length.max(axis=1, keepdims=True)
    order = list(np.argsort(-active.sum(axis=1), kind="stable"))
    rows: list[np.ndarray] = []
    remaining = list(order)
    while remaining if n_expressions is None else len(rows) < n_expressions:
        if not remaining:
            remaining = list(order)
        used = np.zeros(rig.n_vertices, dtype=bool)
        row = np.zeros(rig.n_shapes)
        for shape in list(remaining):
            if not (active[shape] & used).any():
                used |= active[shape]
                row[shape] = 1.0
                remaining.remove(shape)
        rows.append(row)
    return np.array(rows).reshape(-1, rig.n_shapes)
