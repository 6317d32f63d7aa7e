"""Mesh patches for patchwise blendshapes: geodesic k-means, a smooth partition of unity (Wagner 2024)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.cluster.vq import kmeans2
from scipy.sparse.csgraph import connected_components, dijkstra
from scipy.spatial import cKDTree


def edge_graph(neutral: np.ndarray, triangles: np.ndarray) -> sp.csr_matrix:
    """Symmetric ``(N, N)`` matrix of mesh edge lengths (zero-length edges get a tiny positive length)."""
    n_vertices = neutral.shape[0]
    heads = triangles.ravel()
    tails = np.roll(triangles, 1, axis=1).ravel()
    length = np.linalg.norm(neutral[heads] - neutral[tails], axis=1)
    length = np.maximum(length, np.finfo(float).tiny)
    graph = sp.csr_matrix((length, (heads, tails)), shape=(n_vertices, n_vertices))
    return graph.maximum(graph.T).tocsr()


def _grow(graph: sp.csr_matrix, seeds: np.ndarray) -> np.ndarray:
    """Label of the nearest seed along the mesh (multi-source Dijkstra); -1 where none is reachable."""
    _, _, sources = dijkstra(graph, directed=False, indices=seeds, min_only=True, return_predecessors=True)
    position = np.full(graph.shape[0], -1)
    position[seeds] = np.arange(seeds.size)
    return np.where(sources >= 0, position[np.maximum(sources, 0)], -1)


def partition(
    neutral: np.ndarray, triangles: np.ndarray, n_patches: int = 80, *, iterations: int = 5, seed: int = 0
) -> np.ndarray:
    """Split a mesh into compact, connected patches: k-means on positions, grown along the mesh.

    Seeds come from k-means on the vertex positions; every vertex joins the seed nearest along mesh
    edges (so patches are connected), then each seed moves to the patch vertex nearest its centroid,
    ``iterations`` times (geodesic Lloyd relaxation). Vertices no seed reaches (separate mesh parts)
    form one patch per connected part.

    Parameters
    ----------
    neutral : (N, 3) array
    triangles : (T, 3) int array
    n_patches : int
        Wanted number of patches (Wagner et al. use 80); at most N.
    iterations : int
        Lloyd relaxation steps.
    seed : int
        Seed of the k-means initialisation; the same seed gives the same patches.

    Returns
    -------
    (N,) int array of patch labels ``0 .. P-1``.

    Notes
    -----
    O(iterations * E log N) for the Dijkstra growth.
    """
    n_vertices = neutral.shape[0]
    n_patches = max(1, min(int(n_patches), n_vertices))
    graph = edge_graph(neutral, triangles)
    centroids, _ = kmeans2(neutral, n_patches, minit="++", seed=np.random.default_rng(seed))
    _, seeds = cKDTree(neutral).query(centroids)
    seeds = np.unique(seeds)
    labels = _grow(graph, seeds)
    for _ in range(iterations):
        reached = labels >= 0
        counts = np.bincount(labels[reached], minlength=seeds.size)
        sums = np.stack(
            [np.bincount(labels[reached], neutral[reached, axis], seeds.size) for axis in range(3)], axis=1
        )
        centre = sums / np.maximum(counts, 1)[:, None]
        spread = np.where(reached, np.linalg.norm(neutral - centre[np.maximum(labels, 0)], axis=1), np.inf)
        order = np.lexsort((spread, labels))
        order = order[labels[order] >= 0]
        first = np.r_[True, labels[order][1:] != labels[order][:-1]]
        seeds = np.sort(order[first])
        labels = _grow(graph, seeds)
    unreached = labels < 0
    if unreached.any():
        _, part = connected_components(graph, directed=False)
        _, extra = np.unique(part[unreached], return_inverse=True)
        labels[unreached] = seeds.size + extra.ravel()
    _, labels = np.unique(labels, return_inverse=True)
    return labels.ravel()


def blend_weights(labels: np.ndarray, triangles: np.ndarray, rings: int) -> sp.csr_matrix:
    """A smooth partition of unity over the patches: each indicator averaged over ``rings`` mesh rings.

    The patch indicator matrix is multiplied ``rings`` times by the row-stochastic neighbourhood
    average ``S = D^-1 (A + I)``, so each weight falls off over about ``rings`` edges on both sides of a
    patch border, the weights of a vertex still sum to 1, and patches overlap by ``rings`` rings. A
    result blended with these weights has no seams.

    Parameters
    ----------
    labels : (N,) int array
        Patch of each vertex.
    triangles : (T, 3) int array
    rings : int
        Width of the blend; 0 gives the hard (non-overlapping) patches.

    Returns
    -------
    (N, P) CSR matrix with rows summing to 1.
    """
    n_vertices = labels.size
    weights = sp.csr_matrix(
        (np.ones(n_vertices), (np.arange(n_vertices), labels)), shape=(n_vertices, int(labels.max()) + 1)
    )
    if rings <= 0:
        return weights
    heads = triangles.ravel()
    tails = np.roll(triangles, 1, axis=1).ravel()
    adjacency = sp.csr_matrix((np.ones(heads.size), (heads, tails)), shape=(n_vertices, n_vertices))
    adjacency = ((adjacency + adjacency.T + sp.identity(n_vertices)) > 0).astype(np.float64)
    average = sp.diags(1.0 / np.asarray(adjacency.sum(axis=1)).ravel()) @ adjacency
    for _ in range(rings):
        weights = average @ weights
    return weights.tocsr()
