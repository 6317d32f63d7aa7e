"""Polygons to triangles: quads split along their better diagonal, convex n-gons fanned, concave n-gons
ear-clipped in the plane of their Newell normal."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from rigs._obj_faces import Polygons


def triangulate(faces: Sequence[np.ndarray], vertices: np.ndarray) -> np.ndarray:
    """Triangles of polygons, in face order.

    Triangles pass through; a quad is split along its 0-2 diagonal unless the two halves face opposite
    ways (a concave quad), then along 1-3; a convex n-gon is fanned from its first corner, a concave one
    is ear-clipped in the plane of its Newell normal.

    Parameters
    ----------
    faces : sequence of int arrays, or Polygons
        Polygons as vertex indices.
    vertices : (N, 3) float array
        Positions used for the convexity tests.

    Returns
    -------
    (T, 3) int64 array; ``T = sum(len(face) - 2)``.

    Notes
    -----
    Vectorised per polygon size; only concave n-gons (5+ corners) are clipped one by one (see
    `_ear_clip`, expected O(n log n) each).
    """
    if len(faces) == 0:
        return np.zeros((0, 3), dtype=np.int64)
    polygons = Polygons.of(faces)
    if polygons.size == 3:
        return polygons.corners.astype(np.int64, copy=False).reshape(-1, 3)
    sizes, flat, starts = polygons.sizes, polygons.corners.astype(np.int64), polygons.starts[:-1]
    pieces: list[np.ndarray] = []
    owners: list[np.ndarray] = []
    for size in np.unique(sizes):
        members = np.flatnonzero(sizes == size)
        polygons = flat[starts[members][:, None] + np.arange(size)]
        if size == 3:
            triangles = polygons[:, None, :]
        elif size == 4:
            triangles = _split_quads(polygons, vertices)
        else:
            triangles = _split_ngons(polygons, vertices)
        pieces.append(triangles.reshape(-1, 3))
        owners.append(np.repeat(members, size - 2))
    order = np.argsort(np.concatenate(owners), kind="stable")
    return np.concatenate(pieces)[order]


def _split_quads(quads: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    a, b, c, d = (vertices[quads[:, i]] for i in range(4))
    facing = np.einsum("ij,ij->i", np.cross(b - a, c - a), np.cross(c - a, d - a))
    first = np.stack([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]], axis=1)
    second = np.stack([quads[:, [0, 1, 3]], quads[:, [1, 2, 3]]], axis=1)
    return np.where((facing < 0)[:, None, None], second, first)


def _split_ngons(polygons: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    size = polygons.shape[1]
    points = vertices[polygons]
    normal = np.cross(points, np.roll(points, -1, axis=1)).sum(axis=1)
    turns = np.cross(points - np.roll(points, 1, axis=1), np.roll(points, -1, axis=1) - points)
    scale = np.linalg.norm(normal, axis=1, keepdims=True) ** 2 + np.finfo(float).tiny
    convex = (np.einsum("fij,fj->fi", turns, normal) >= -1e-12 * scale).all(axis=1)
    fan = np.arange(1, size - 1)
    triangles = np.stack(
        [np.repeat(polygons[:, :1], size - 2, axis=1), polygons[:, fan], polygons[:, fan + 1]], axis=2
    )
    for i in np.flatnonzero(~convex):
        triangles[i] = polygons[i][_ear_clip(points[i], normal[i])]
    return triangles


def _ear_clip(points: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """Corner triples of an ear-clipped simple polygon (corners counter-clockwise about ``normal``).

    The clipper works in rounds over the corners that may be ears, in corner order from corner 0: an ear
    (a strictly convex corner whose triangle holds no other corner, boundary included) is clipped, and
    its two neighbours wait for the next round. So one round clips ears that are not adjacent, and the
    triangles stay local (a convex polygon is halved round by round instead of fanned from one corner).
    When a round clips nothing (a self-intersecting polygon), one corner is clipped anyway.

    Notes
    -----
    Only corners that are not strictly convex can lie in an ear's triangle (Meisters 1975), so only those
    are tested, found through a KD-tree of their positions (`_Reflex`). A corner's status changes only
    when a neighbour is clipped or the reflex corner that blocked it (its witness) becomes convex or is
    clipped; exactly those corners are tested again, so reflex corners are never walked over. Expected
    O(n log n) for the polygons of real meshes: 8,000-corner stars, combs and spirals take a fraction of
    a second, where re-scanning every corner after each clip took seconds.
    """
    axis = int(np.argmax(np.abs(normal)))
    plane = np.delete(points, axis, axis=1)
    if (normal[axis] < 0) != (axis == 1):
        plane = plane[:, ::-1]
    n = len(plane)
    before, after = [n - 1, *range(n - 1)], [*range(1, n), 0]
    reflex = _Reflex(plane, _cross2(plane - plane[before], plane[after] - plane) <= 0)
    waiting: dict[int, list[int]] = {}  # witness -> the corners it blocks
    removed = [False] * n
    triangles: list[tuple[int, int, int]] = []
    later: list[int] = []

    def retire(corner: int) -> None:
        if reflex.alive[corner]:
            reflex.retire(corner)
            later.extend(waiting.pop(corner, ()))

    def clip(corner: int) -> None:
        previous, following = before[corner], after[corner]
        triangles.append((previous, corner, following))
        after[previous], before[following] = following, previous
        removed[corner] = True
        retire(corner)
        for neighbour in (previous, following):
            if not reflex.reflex_at(before[neighbour], neighbour, after[neighbour]):
                retire(neighbour)
        later.extend((previous, following))

    current = np.flatnonzero(~reflex.alive).tolist()
    lowest = 0
    while len(triangles) < n - 3:
        later.clear()
        touched: set[int] = set()
        for corner in current:
            if len(triangles) == n - 3:
                break
            if removed[corner] or corner in touched:
                continue
            witness = reflex.blocker(before[corner], corner, after[corner])
            if witness is None:
                touched.update((before[corner], after[corner]))
                clip(corner)
            elif witness >= 0:
                waiting.setdefault(witness, []).append(corner)
        if not later and len(triangles) < n - 3:  # a round without an ear
            while removed[lowest]:
                lowest += 1
            clip(after[lowest])
        current = sorted({corner for corner in later if not removed[corner]})
    while removed[lowest]:
        lowest += 1
    triangles.append((before[lowest], lowest, after[lowest]))
    return np.asarray(triangles, dtype=np.int64)


class _Reflex:
    """The corners of a polygon that are not strictly convex, with a KD-tree to find those in a triangle."""

    #: Below this many reflex corners a direct test is faster than the tree.
    DIRECT = 32

    def __init__(self, plane: np.ndarray, reflex: np.ndarray) -> None:
        self.plane = plane
        self.points = plane.tolist()
        self.alive = reflex.copy()
        self._index(np.flatnonzero(reflex))

    def _index(self, indices: np.ndarray) -> None:
        from scipy.spatial import cKDTree  # (only concave n-gons need it)

        self.indices = indices
        self.tree = cKDTree(self.plane[indices]) if len(indices) > self.DIRECT else None
        self.count = len(indices)

    def reflex_at(self, before: int, corner: int, after: int) -> bool:
        (ax, ay), (bx, by), (cx, cy) = self.points[before], self.points[corner], self.points[after]
        return (bx - ax) * (cy - by) - (by - ay) * (cx - bx) <= 0

    def retire(self, corner: int) -> None:
        """``corner`` was clipped or became convex; the tree is rebuilt when half its corners are retired."""
        self.alive[corner] = False
        self.count -= 1
        if 2 * self.count < len(self.indices):
            self._index(self.indices[self.alive[self.indices]])

    def blocker(self, before: int, corner: int, after: int) -> int | None:
        """None when ``corner`` is an ear; -1 when it is not strictly convex; else a reflex corner inside
        its triangle (boundary included)."""
        if self.reflex_at(before, corner, after):
            return -1
        if self.count == 0:
            return None
        (ax, ay), (bx, by), (cx, cy) = self.points[before], self.points[corner], self.points[after]
        if self.tree is None:
            candidates = self.indices
        else:
            low_x, high_x, low_y, high_y = min(ax, bx, cx), max(ax, bx, cx), min(ay, by, cy), max(ay, by, cy)
            radius = 0.5 * math.hypot(high_x - low_x, high_y - low_y) * (1 + 1e-9) + 1e-300
            found = self.tree.query_ball_point((0.5 * (low_x + high_x), 0.5 * (low_y + high_y)), radius)
            candidates = self.indices[found]
        candidates = candidates[
            self.alive[candidates] & (candidates != before) & (candidates != corner) & (candidates != after)
        ]
        if not candidates.size:
            return None
        px, py = self.plane[candidates, 0], self.plane[candidates, 1]
        inside = (
            ((bx - ax) * (py - ay) - (by - ay) * (px - ax) >= 0)
            & ((cx - bx) * (py - by) - (cy - by) * (px - bx) >= 0)
            & ((ax - cx) * (py - cy) - (ay - cy) * (px - cx) >= 0)
        )
        hits = np.flatnonzero(inside)
        return int(candidates[hits[0]]) if hits.size else None


def _cross2(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def faces_are_triangles(faces: Sequence[np.ndarray]) -> bool:
    """True when every polygon has three corners (the triangles are then the faces)."""
    if isinstance(faces, Polygons):
        return bool((faces.sizes == 3).all())
    return all(len(face) == 3 for face in faces)
