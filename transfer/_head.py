"""The volumetric head of anatomical deformation transfer, built from the rig itself (Wagner 2024, 3.3.2).

The paper fits a head template ``H = (soft tissue, muscle, skull)`` made from computed tomography to each
neutral (``fitHead``, eq. 7): a skull placed by a model learnt from CT scans, tissue warped in by radial
basis functions. No such template ships with a rig, so `HeadTemplate.build` makes one from the template
rig's own surface, and `HeadTemplate.fit` places it under any neutral of the same topology:

- **Skin.** The skin components (those with at least a quarter of the largest one's vertices: eyeballs,
  teeth, tongue and lashes are left out) are split into compact clusters (`transfer._partition`),
  one coarse vertex per cluster (its vertex nearest the cluster's centroid); three clusters meeting at a
  triangle give a coarse triangle (the dual of the clusters). The simulation runs on this coarse skin;
  every skin vertex is embedded in a tetrahedron of it by affine coordinates, so the rig's surface
  follows the volume exactly at rest.
- **Skull.** The skull is the coarse skin offset inward along its normals by a tissue thickness that
  depends on the region (`tissue_thickness`): thin on the forehead and the nose bridge, thick on the
  cheeks and lips, in proportion to the face's size. Skull vertices follow the jaw when the rig's jaw
  opening shape moves their skin (`jaw_shape`), else the cranium; a rig without one has one rigid skull.
- **Tissue.** Two prism layers between skin and skull, split into three tetrahedra each along diagonals
  chosen from vertex indices (so neighbouring prisms agree): the outer half is soft tissue, the inner
  half muscle, connected to both (Fig. 3).

Thickness is a fraction of the skin's bounding-box diagonal, so a uniformly scaled head is the scaled
head, and where an offset would turn a tetrahedron inside out, the thickness is halved there.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from transfer._features import Features
from transfer._frames import rigid_rotation
from transfer._partition import metis_partition

#: Skin components have at least this share of the largest component's vertices.
SKIN_SHARE = 0.25
#: Tissue thickness by region, as fractions of the skin's bounding-box diagonal (about 5, 3, 18, 12 and
#: 9 mm on an adult face).
THICKNESS = {"forehead": 0.02, "nose_bridge": 0.012, "cheek": 0.06, "lips": 0.045, "chin": 0.035}
#: Prism layers from skin to skull; the outer ``SOFT_LAYERS`` are soft tissue, the others muscle.
LAYERS, SOFT_LAYERS = 2, 1
#: Shapes named like a jaw opening.
_JAW_NAME = re.compile(r"jaw[\W_]*open", re.IGNORECASE)
#: A skull vertex follows the jaw when its skin moves at least this share of the jaw shape's largest motion;
#: the jaw's position is measured on the skin that moves at least ``_JAW_TRACK``.
_JAW_BONE, _JAW_TRACK = 0.5, 0.8
#: The cranium's position is measured on skin that every shape moves by at most this share of the rig's
#: largest motion.
_STILL = 0.02
#: Halvings of the thickness where a tetrahedron would be inverted or flattened: a tetrahedron must keep
#: ``_KEEP`` of the volume that a thin shell's, scaled up to its thickness, promises.
_SHRINK_STEPS, _KEEP = 4, 0.05
#: Rounds of averaging the inward directions over neighbouring coarse vertices.
_NORMAL_SMOOTHING = 2
#: Coarse triangles whose area is below this share of their squared longest edge are slivers (an
#: equilateral triangle has 0.43).
_SLIVER = 0.05


def skin_vertices(n_vertices: int, triangles: np.ndarray) -> np.ndarray:
    """``(N,)`` mask of the skin: the components with at least `SKIN_SHARE` of the largest one's vertices."""
    heads, tails = triangles.ravel(), np.roll(triangles, 1, axis=1).ravel()
    graph = sp.csr_matrix((np.ones(heads.size), (heads, tails)), shape=(n_vertices, n_vertices))
    _, label = connected_components(graph, directed=False)
    counts = np.bincount(label)
    used = np.zeros(n_vertices, dtype=bool)
    used[triangles.ravel()] = True
    return (counts[label] >= SKIN_SHARE * counts[label[used]].max()) & used


def vertex_normals(positions: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals, ``(N, 3)`` (zero where no triangle touches a vertex)."""
    corners = positions[triangles]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    summed = np.zeros_like(positions)
    for corner in range(3):
        np.add.at(summed, triangles[:, corner], normals)
    return summed


def jaw_shape(names: tuple[str, ...], deltas: np.ndarray, neutral: np.ndarray, up: np.ndarray) -> int | None:
    """The rig's jaw-opening shape: named ``jawOpen`` (any case and separator), else the most rigid of the
    shapes that move the lower face most; None when no shape moves rigidly below the face's middle.

    Parameters
    ----------
    names : tuple of str
    deltas : (K, N, 3) array
    neutral : (N, 3) array
    up : (3,) array
        The face's up direction (`rigs.frontal_camera`).
    """
    for index, name in enumerate(names):
        if _JAW_NAME.search(name):
            return index
    height = (neutral - neutral.mean(axis=0)) @ up
    best, best_score = None, 0.0
    for index, delta in enumerate(deltas):
        length = np.linalg.norm(delta, axis=1)
        moving = length >= 0.5 * length.max()
        if length.max() <= 0 or moving.sum() < 4 or height[moving].mean() >= 0:
            continue
        rotation = rigid_rotation(neutral[moving], neutral[moving] + delta[moving])
        centred = neutral[moving] - neutral[moving].mean(axis=0)
        moved = neutral[moving] + delta[moving]
        residual = moved - moved.mean(axis=0) - centred @ rotation.T
        rigidity = 1.0 - np.sqrt(np.mean(np.sum(residual**2, axis=1))) / np.mean(length[moving])
        score = rigidity * np.mean(length[moving]) * moving.sum()
        if rigidity > 0.8 and score > best_score:
            best, best_score = index, score
    return best


def _smoothstep(value: np.ndarray, low: float, high: float) -> np.ndarray:
    ramp = np.clip((value - low) / (high - low), 0.0, 1.0)
    return ramp * ramp * (3.0 - 2.0 * ramp)


def tissue_thickness(points: np.ndarray, camera: np.ndarray, features: Features) -> np.ndarray:
    """Relative soft-tissue thickness at ``points`` by facial region (fractions of the face's diagonal).

    Regions come from the face's frame: heights are measured from the mouth (0) to the eyes (1) where
    the features show them, else at 30 % and 62 % of the face's height. The forehead lies above the
    eyes, the nose bridge near the symmetry plane between the nose and the eyes, the lips around the
    mouth and the chin below it; the cheeks are the rest (`THICKNESS`).

    Parameters
    ----------
    points : (C, 3) array
        The coarse skin of the template neutral.
    camera : (3, 3) array
        Rows right, up, towards the viewer.
    features : Features

    Returns
    -------
    (C,) array.
    """
    centre = points.mean(axis=0)
    local = (points - centre) @ camera.T
    across, height = local[:, 0], local[:, 1]
    half_width = float(np.abs(across).max()) or 1.0
    low, high = float(height.min()), float(height.max())
    mouth = low + 0.3 * (high - low)
    eyes = low + 0.62 * (high - low)
    if features.mouth_centre is not None:
        mouth = float((features.mouth_centre - centre) @ camera[1])
    if features.eye_centres is not None:
        eyes = float(np.mean((features.eye_centres - centre) @ camera[1]))
    if eyes <= mouth:
        eyes = mouth + 0.32 * (high - low)
    level = (height - mouth) / (eyes - mouth)
    side = np.abs(across) / half_width
    forehead = _smoothstep(level, 1.1, 1.5)
    bridge = (1.0 - _smoothstep(side, 0.08, 0.18)) * _smoothstep(level, 0.35, 0.6) * (1.0 - forehead)
    lips = np.exp(-((level / 0.22) ** 2) - (side / 0.35) ** 2)
    chin = _smoothstep(-level, 0.3, 0.6)
    thickness = np.full(len(points), THICKNESS["cheek"])
    for weight, region in ((chin, "chin"), (lips, "lips"), (forehead, "forehead"), (bridge, "nose_bridge")):
        thickness = (1.0 - weight) * thickness + weight * THICKNESS[region]
    return thickness


def _coarse_triangles(labels: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Triangles of clusters that meet at a mesh triangle (the dual of the clusters), once each."""
    corners = labels[triangles]
    distinct = (
        (corners[:, 0] != corners[:, 1]) & (corners[:, 1] != corners[:, 2]) & (corners[:, 0] != corners[:, 2])
    )
    found = corners[distinct]
    _, first = np.unique(np.sort(found, axis=1), axis=0, return_index=True)
    return found[np.sort(first)]


def _well_shaped(points: np.ndarray, surface: np.ndarray) -> np.ndarray:
    """Coarse triangles that are not slivers: area at least `_SLIVER` of the squared longest edge."""
    corners = points[surface]
    edges = corners - np.roll(corners, 1, axis=1)
    area = 0.5 * np.linalg.norm(np.cross(edges[:, 0], edges[:, 1]), axis=1)
    longest = np.max(np.sum(edges**2, axis=2), axis=1)
    return area >= _SLIVER * longest


def _prism_tets(coarse: np.ndarray, n_coarse: int) -> tuple[np.ndarray, np.ndarray]:
    """Tetrahedra of the prism layers and layers; vertex vertex ``l * C + c`` is coarse vertex c on layer l.

    Each prism's top triangle is sorted by vertex index ``a < b < c``; its tetrahedra are
    ``(a, b, c, a')``, ``(b, c, a', b')`` and ``(c, a', b', c')`` (primes on the layer below), so every
    quadrilateral side is cut from its higher-index top vertex to its lower-index bottom one, the same
    way for both prisms that share it.
    """
    a, b, c = np.sort(coarse, axis=1).T
    tets, layers = [], []
    for layer in range(LAYERS):
        top, bottom = layer * n_coarse, (layer + 1) * n_coarse
        for tet in (
            (a + top, b + top, c + top, a + bottom),
            (b + top, c + top, a + bottom, b + bottom),
            (c + top, a + bottom, b + bottom, c + bottom),
        ):
            tets.append(np.stack(tet, axis=1))
            layers.append(np.full(len(a), layer))
    return np.concatenate(tets), np.concatenate(layers)


def signed_volumes(positions: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Signed volumes of tetrahedra."""
    corners = positions[tets]
    edges = corners[:, 1:] - corners[:, :1]
    return np.linalg.det(edges) / 6.0


def rigid_fit(rest: np.ndarray, moved: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotations and translations ``moved ~ R (rest - mean(rest)) + mean(rest) + t``, batched over shapes.

    Parameters
    ----------
    rest : (P, 3) array
    moved : (B, P, 3) array

    Returns
    -------
    (B, 3, 3) rotations and (B, 3) translations of the centroid; a rotation is the identity with fewer
    than three points.
    """
    centre = rest.mean(axis=0)
    moved_centre = moved.mean(axis=1)
    translation = moved_centre - centre
    if len(rest) < 3:
        return np.broadcast_to(np.eye(3), (len(moved), 3, 3)).copy(), translation
    covariance = np.swapaxes(moved - moved_centre[:, None], 1, 2) @ (rest - centre)
    left, _, right = np.linalg.svd(covariance)
    sign = np.sign(np.linalg.det(left @ right))
    sign[sign == 0] = 1.0
    left[:, :, 2] *= sign[:, None]
    return left @ right, translation


@dataclass(frozen=True)
class Head:
    """A head template placed under one neutral: ``H_S`` or ``H_T`` of eq. 7.

    Attributes
    ----------
    neutral : (N, 3) array
        The neutral the head is fitted to.
    rest : (V, 3) array
        Volume vertices: layer 0 is the coarse skin, the last layer the skull.
    embedding : (N, V) sparse matrix
        Affine coordinates of every embedded rig vertex in its tetrahedron (rows of other vertices are 0).
    size : float
        Bounding-box diagonal of the skin (``BB`` of sec. 3.3.2).
    jaw_centre, cranium_centre : (3,) arrays
        Centroids of the skin that measures each bone's motion (the centres of its rotations).
    """

    neutral: np.ndarray
    rest: np.ndarray
    embedding: sp.csr_matrix
    size: float
    jaw_centre: np.ndarray
    cranium_centre: np.ndarray


@dataclass(frozen=True)
class HeadTemplate:
    """The topology of the volumetric head, made once from the template rig (`build`), fitted per neutral.

    Attributes
    ----------
    skin : (N,) bool array
        Rig vertices of the simulated skin.
    triangles : (F, 3) int array
        The rig's triangles on the skin.
    coarse : (C,) int array
        The rig vertex of each coarse skin vertex.
    cluster : (N,) int array
        Coarse vertex of each skin vertex's cluster (-1 off the skin).
    surface : (F, 3) int array
        Coarse skin triangles.
    tets : (T, 4) int array
        Tetrahedra over the volume vertices ``layer * C + c``.
    soft : (T,) bool array
        Soft-tissue tetrahedra (the others are muscle).
    kept : (T,) bool array
        Tetrahedra that the simulation uses: those the template's offset leaves at least `_KEEP` of their
        expected volume after the thickness is halved `_SHRINK_STEPS` times (the others are flat).
    thickness : (C,) array
        Tissue thickness under each coarse vertex, a fraction of the skin's diagonal.
    jaw : (C,) bool array
        Skull vertices that follow the jaw.
    embed_tet : (N,) int array
        Tetrahedron of each rig vertex (-1 when not embedded).
    jaw_track, cranium_track : int arrays
        Rig vertices whose motion gives the jaw's and the cranium's rigid motion (Fig. 4).
    """

    skin: np.ndarray
    triangles: np.ndarray
    coarse: np.ndarray
    cluster: np.ndarray
    surface: np.ndarray
    tets: np.ndarray
    soft: np.ndarray
    kept: np.ndarray
    thickness: np.ndarray
    jaw: np.ndarray
    embed_tet: np.ndarray
    jaw_track: np.ndarray
    cranium_track: np.ndarray

    @property
    def n_coarse(self) -> int:
        return int(self.coarse.size)

    @property
    def skull(self) -> np.ndarray:
        """Volume indices of the skull vertices."""
        return LAYERS * self.n_coarse + np.arange(self.n_coarse)

    @classmethod
    def build(
        cls,
        neutral: np.ndarray,
        deltas: np.ndarray,
        triangles: np.ndarray,
        names: tuple[str, ...],
        camera: np.ndarray,
        features: Features,
        resolution: int,
        seed: int = 0,
    ) -> HeadTemplate:
        """The head template of a rig (its neutral, shapes and face frame).

        Parameters
        ----------
        neutral : (N, 3) array
        deltas : (K, N, 3) array
        triangles : (T, 3) int array
        names : tuple of str
        camera : (3, 3) array
            Rows right, up, towards the viewer (`rigs.frontal_camera`).
        features : Features
        resolution : int
            Wanted number of coarse skin vertices (at most a third of the skin's).
        seed : int
            Seed of the clusters.
        """
        n_vertices = neutral.shape[0]
        skin = skin_vertices(n_vertices, triangles)
        members = np.flatnonzero(skin)
        local_index = np.full(n_vertices, -1)
        local_index[members] = np.arange(members.size)
        skin_triangles = local_index[triangles[skin[triangles].all(axis=1)]]
        count = max(4, min(int(resolution), members.size // 3))
        labels = metis_partition(neutral[members], skin_triangles, count, seed=seed)
        n_coarse = int(labels.max()) + 1
        centroid = np.stack([np.bincount(labels, neutral[members, axis]) for axis in range(3)], axis=1)
        centroid /= np.bincount(labels)[:, None]
        spread = np.linalg.norm(neutral[members] - centroid[labels], axis=1)
        order = np.lexsort((spread, labels))
        coarse = members[order[np.r_[True, labels[order][1:] != labels[order][:-1]]]]
        cluster = np.full(n_vertices, -1)
        cluster[members] = labels
        surface = _coarse_triangles(labels, skin_triangles)
        surface = surface[_well_shaped(neutral[coarse], surface)]
        tets, layer = _prism_tets(surface, n_coarse)
        points = neutral[coarse]
        relative = tissue_thickness(points, camera, features)
        jaw_index = jaw_shape(names, deltas, neutral, camera[1])
        if jaw_index is None:
            jaw = np.zeros(n_coarse, dtype=bool)
            jaw_track = np.zeros(0, dtype=np.intp)
        else:
            motion = np.linalg.norm(deltas[jaw_index], axis=1) * skin
            cluster_motion = np.bincount(labels, motion[members]) / np.bincount(labels)
            jaw = cluster_motion >= _JAW_BONE * motion.max()
            jaw_track = np.flatnonzero(motion >= _JAW_TRACK * motion.max())
        overall = (
            np.linalg.norm(deltas, axis=2).max(axis=0, initial=0.0) if len(deltas) else np.zeros(n_vertices)
        )
        still = skin & (overall <= _STILL * overall.max(initial=0.0))
        if jaw.any():
            still[jaw_track] = False
        if still.sum() < 3:
            candidates = members[np.argsort(overall[members], kind="stable")]
            still = np.zeros(n_vertices, dtype=bool)
            still[candidates[: max(3, candidates.size // 20)]] = True
        template = cls(
            skin=skin,
            triangles=triangles[skin[triangles].all(axis=1)],
            coarse=coarse,
            cluster=cluster,
            surface=surface,
            tets=tets,
            soft=layer < SOFT_LAYERS,
            kept=np.ones(len(tets), dtype=bool),
            thickness=relative,
            jaw=jaw,
            embed_tet=np.full(n_vertices, -1),
            jaw_track=jaw_track,
            cranium_track=np.flatnonzero(still),
        )
        flipped = template._orientation(neutral) < 0
        tets[flipped] = tets[flipped][:, [0, 1, 3, 2]]
        rest, thickness, quality = template._volume(neutral)
        template = cls(
            **{
                **template.__dict__,
                "tets": tets,
                "kept": quality >= _KEEP,
                "thickness": thickness / _diagonal(neutral[members]),
            }
        )
        embed = template._embed_tets(neutral, rest)
        return cls(**{**template.__dict__, "embed_tet": embed})

    def _inward(self, neutral: np.ndarray) -> np.ndarray:
        """Unit inward normals of the coarse skin: the skin normals averaged over each cluster."""
        members = self.skin
        normals = vertex_normals(neutral, self.triangles)
        summed = np.stack(
            [np.bincount(self.cluster[members], normals[members, axis], self.n_coarse) for axis in range(3)],
            axis=1,
        )
        points = neutral[self.coarse]
        if np.sum(summed * (points - points.mean(axis=0))) < 0:
            summed = -summed
        heads, tails = self.surface.ravel(), np.roll(self.surface, 1, axis=1).ravel()
        average = sp.csr_matrix(
            (np.ones(heads.size), (heads, tails)), shape=(self.n_coarse, self.n_coarse)
        ) + sp.identity(self.n_coarse)
        for _ in range(_NORMAL_SMOOTHING):
            length = np.linalg.norm(summed, axis=1, keepdims=True)
            summed = average @ (summed / np.where(length > 0, length, 1.0))
        length = np.linalg.norm(summed, axis=1, keepdims=True)
        return -summed / np.where(length > 0, length, 1.0)

    def _layers(self, neutral: np.ndarray, thickness: np.ndarray) -> np.ndarray:
        """Volume vertices: the coarse skin offset inward by ``l / LAYERS`` of the absolute ``thickness``."""
        depth = np.arange(LAYERS + 1)[:, None, None] / LAYERS
        return (
            neutral[self.coarse][None] + depth * thickness[None, :, None] * self._inward(neutral)[None]
        ).reshape(-1, 3)

    def _orientation(self, neutral: np.ndarray) -> np.ndarray:
        """Signed volumes of the tetrahedra of a thin shell (a thousandth of the thickness): their sign."""
        thin = 1e-3 * self.thickness * _diagonal(neutral[self.skin])
        return signed_volumes(self._layers(neutral, thin), self.tets)

    def _volume(self, neutral: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Volume vertices under ``neutral``, the absolute thickness used and each tetrahedron's quality.

        The quality is a tetrahedron's volume over the volume of a thin shell's (a thousandth of the
        thickness) scaled up to its thickness; the thickness is halved under every kept tetrahedron of
        quality below `_KEEP`, at most `_SHRINK_STEPS` times.
        """
        diagonal = _diagonal(neutral[self.skin])
        full = self.thickness * diagonal
        thickness = full.copy()
        thin = self._orientation(neutral)
        expected = 1e3 * np.where(np.abs(thin) > 0, np.abs(thin), np.inf)
        for step in range(_SHRINK_STEPS + 1):
            rest = self._layers(neutral, thickness)
            share = (thickness / full)[self.tets % self.n_coarse].mean(axis=1)
            quality = signed_volumes(rest, self.tets) * np.sign(thin) / (expected * share)
            bad = (quality < _KEEP) & self.kept
            if not bad.any() or step == _SHRINK_STEPS:
                break
            thickness[np.unique(self.tets[bad] % self.n_coarse)] *= 0.5
        return rest, thickness, quality

    def _embed_tets(self, neutral: np.ndarray, rest: np.ndarray) -> np.ndarray:
        """Soft-tissue tetrahedron of each skin vertex: among the prisms of coarse triangles at its
        cluster's coarse vertex (or its neighbours'), the one whose triangle best contains it."""
        n_coarse = self.n_coarse
        n_surface = len(self.surface)
        incidence = sp.csr_matrix(
            (np.ones(self.surface.size), (self.surface.ravel(), np.repeat(np.arange(n_surface), 3))),
            shape=(n_coarse, n_surface),
        )
        corners = self.cluster[self.triangles]
        heads, tails = corners.ravel(), np.roll(corners, 1, axis=1).ravel()
        neighbours = sp.csr_matrix((np.ones(heads.size), (heads, tails)), shape=(n_coarse, n_coarse))
        lonely = sp.diags((np.diff(incidence.indptr) == 0).astype(float))
        around = (incidence + lonely @ neighbours @ incidence).tocsr()
        around.data[:] = 1.0
        around.sort_indices()
        members = np.flatnonzero(self.skin)
        owner = self.cluster[members]
        counts = np.diff(around.indptr)[owner]
        width = int(counts.max(initial=0))
        embed = np.full(neutral.shape[0], -1)
        if width == 0:
            return embed
        slots = np.arange(width)
        valid = slots[None] < counts[:, None]
        start = around.indptr[owner]
        candidate = np.where(
            valid, around.indices[np.minimum(start[:, None] + slots[None], around.nnz - 1)], 0
        )
        # The prism of coarse triangle f on layer 0 holds tetrahedra f, F + f and 2F + f (see _prism_tets).
        options = (candidate[:, :, None] + np.arange(3) * n_surface).reshape(members.size, -1)
        coordinates = _affine(rest[self.tets[options]], neutral[members][:, None])
        score = coordinates.min(axis=2)
        score[~np.repeat(valid, 3, axis=1) | ~self.kept[options]] = -np.inf
        choice = options[np.arange(members.size), np.argmax(score, axis=1)]
        has = np.isfinite(score.max(axis=1))
        embed[members[has]] = choice[has]
        return embed

    def fit(self, neutral: np.ndarray) -> Head:
        """The head under ``neutral`` (``fitHead``, eq. 7): volume vertices and the rig's embedding."""
        rest, _, _ = self._volume(neutral)
        embedded = np.flatnonzero(self.embed_tet >= 0)
        corners = self.tets[self.embed_tet[embedded]]
        coordinates = _affine(rest[corners][:, None], neutral[embedded][:, None])[:, 0, :]
        embedding = sp.csr_matrix(
            (coordinates.ravel(), (np.repeat(embedded, 4), corners.ravel())),
            shape=(neutral.shape[0], rest.shape[0]),
        )
        return Head(
            neutral=neutral,
            rest=rest,
            embedding=embedding,
            size=_diagonal(neutral[self.skin]),
            jaw_centre=neutral[self.jaw_track].mean(axis=0) if self.jaw_track.size else np.zeros(3),
            cranium_centre=neutral[self.cranium_track].mean(axis=0),
        )


def _diagonal(points: np.ndarray) -> float:
    return float(np.linalg.norm(np.ptp(points, axis=0))) or 1.0


def _containment(corners: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Smallest barycentric coordinate of each point's projection onto each triangle (higher is inside)."""
    first = corners[..., 0, :]
    e1, e2 = corners[..., 1, :] - first, corners[..., 2, :] - first
    offset = points - first
    d11, d12, d22 = (e1 * e1).sum(-1), (e1 * e2).sum(-1), (e2 * e2).sum(-1)
    p1, p2 = (offset * e1).sum(-1), (offset * e2).sum(-1)
    det = d11 * d22 - d12 * d12
    det = np.where(np.abs(det) > 0, det, 1.0)
    u = (d22 * p1 - d12 * p2) / det
    v = (d11 * p2 - d12 * p1) / det
    return np.minimum(np.minimum(u, v), 1.0 - u - v)


def _affine(corners: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Affine coordinates ``(..., 4)`` of points in tetrahedra ``(..., 4, 3)`` (negative outside)."""
    first = corners[..., 0, :]
    edges = np.swapaxes(corners[..., 1:, :] - first[..., None, :], -1, -2)
    local = np.linalg.solve(edges, (points - first)[..., None])[..., 0]
    return np.concatenate((1.0 - local.sum(axis=-1, keepdims=True), local), axis=-1)
