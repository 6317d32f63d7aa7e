"""Welding the vertices exporters split along UV and normal seams."""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree


def collapsed(triangles: np.ndarray) -> np.ndarray:
    """(T,) bool: triangles with two equal corners."""
    return (
        (triangles[:, 0] == triangles[:, 1])
        | (triangles[:, 1] == triangles[:, 2])
        | (triangles[:, 0] == triangles[:, 2])
    )


def weld_seams(
    neutral: np.ndarray, deltas: np.ndarray, triangles: np.ndarray, tolerance: float = 1e-6
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Merge coincident vertices whose displacements agree in every blendshape.

    Parameters
    ----------
    neutral : (V, 3) array
    deltas : (K, V, 3) array
    triangles : (T, 3) int array
    tolerance : float
        Relative to the neutral's bounding-box diagonal, for positions and displacements alike.

    Returns
    -------
    neutral (N, 3), deltas (K, N, 3), triangles (T', 3) with collapsed triangles dropped, and the
    (V,) map from input vertex to welded vertex. Welded vertices keep the order of first occurrence.

    Notes
    -----
    Candidate pairs from a KD-tree ball query, O(V log V); merged by connected components.
    """
    absolute = tolerance * float(np.linalg.norm(np.ptp(neutral, axis=0)))
    pairs = cKDTree(neutral).query_pairs(absolute, output_type="ndarray")
    if len(pairs) and len(deltas):
        gap = np.abs(deltas[:, pairs[:, 0]] - deltas[:, pairs[:, 1]]).max(axis=(0, 2))
        pairs = pairs[gap <= absolute]
    n = len(neutral)
    graph = (
        coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n)) if len(pairs) else None
    )
    if graph is None:
        return neutral, deltas, triangles, np.arange(n)
    _, labels = connected_components(graph, directed=False)
    _, first = np.unique(labels, return_index=True)
    keep = np.sort(first)
    renumber = np.empty(labels.max() + 1, dtype=np.int64)
    renumber[labels[keep]] = np.arange(len(keep))
    vertex_map = renumber[labels]
    welded = vertex_map[triangles]
    return neutral[keep], deltas[:, keep], welded[~collapsed(welded)], vertex_map
