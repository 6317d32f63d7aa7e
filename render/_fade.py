"""Where a face was cut out of a larger mesh: its picture fades out towards the cut.

A face rig is often a part of a whole character, cropped to what its shapes move (the Face Units rig keeps
two rings of faces around them): the cut follows the polygons it kept, a staircase of whole faces across the
top of the head, behind the ears and across the neck. Drawn as it is, that jagged edge is the first thing a
picture shows. The cut is an open edge of the mesh that no shape moves (an eyelid's or the lips' edges
move with their shapes, and stay as they are); `edge_fade` gives every vertex an opacity that rises from 0
on such an edge to 1 a few of its edge lengths inside, smoothly, so the picture ends in a soft vignette
whose outline is far smoother than the staircase (the distance to a jagged line has round level lines).
"""

from __future__ import annotations

import numpy as np

#: A loop of open edges is a cut when its vertices move less than this share of the rig's largest motion
#: and it spans at least `_SPAN` of the mesh's bounding-box diagonal (a neck's cut does, the inside of the
#: mouth or an eye socket does not).
_STILL, _SPAN = 0.1, 0.25
#: The fade's width in median edge lengths of the cut: the staircase of a crop is a face or two deep.
_WIDTH = 3.0


def open_edges(triangles: np.ndarray, count: int) -> np.ndarray:
    """(E, 2) the edges of ``triangles`` (over ``count`` vertices) that only one triangle has: the mesh's
    open edges, lower vertex first."""
    triangles = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    edges = np.sort(triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    keys, uses = np.unique(edges[:, 0] * count + edges[:, 1], return_counts=True)
    single = keys[uses == 1]
    return np.stack([single // count, single % count], axis=1)


def edge_fade(vertices: np.ndarray, triangles: np.ndarray, motion: np.ndarray) -> np.ndarray | None:
    """(N,) opacity of each vertex: 0 on the open edges where the mesh was cut (loops of open edges that no
    shape moves much and that span a good part of the mesh), rising smoothly (smoothstep) to 1 at
    `_WIDTH` median edge lengths of the cut from it; None when the mesh has no such cut (a closed head, or
    a face whose every open edge moves). A seam (twin vertices, `render.coincident`) is no open edge.

    Parameters
    ----------
    vertices : (N, 3) array
        The neutral.
    triangles : (T, 3) int array
    motion : (N,) array
        How far each vertex moves, at most, in any shape.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    from render._raster import coincident

    vertices = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    count = len(vertices)
    edges = open_edges(coincident(vertices)[np.asarray(triangles, dtype=np.intp)], count)  # (a seam is shut)
    motion = np.asarray(motion, dtype=np.float64)
    if not len(edges) or not count:
        return None
    links = coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(count, count))
    _, loop = connected_components(links, directed=False)
    ends = np.unique(edges)
    loops = loop.max() + 1
    largest, low, high = np.zeros(loops), np.full((loops, 3), np.inf), np.full((loops, 3), -np.inf)
    np.maximum.at(largest, loop[ends], motion[ends])
    np.minimum.at(low, loop[ends], vertices[ends])
    np.maximum.at(high, loop[ends], vertices[ends])
    span = np.linalg.norm(np.where(np.isfinite(high), high - low, 0.0), axis=1)
    diagonal = float(np.linalg.norm(np.ptp(vertices, axis=0)))
    still = (largest <= _STILL * max(float(motion.max()), 1e-300)) & (span >= _SPAN * diagonal)
    cut = edges[still[loop[edges[:, 0]]]]
    if not len(cut):
        return None
    width = _WIDTH * float(np.median(np.linalg.norm(vertices[cut[:, 0]] - vertices[cut[:, 1]], axis=1)))
    if width <= 0:
        return None
    distance, _ = cKDTree(vertices[np.unique(cut)]).query(vertices)
    ramp = np.clip(distance / width, 0.0, 1.0)
    return ramp * ramp * (3.0 - 2.0 * ramp)
