"""Facial characteristics of AnaConDaR: eye openings, eye sockets, lip contour (Wagner 2024, eqs. 15-17).

The paper draws supplementary triangles between the upper and lower eyelids (EO) and between the upper and
lower boundaries of the eye sockets (ES) on its head template, and marks the vertices of the lip contour
(LC) (Fig. 4). No such template ships with a rig, so `find_features` derives them from the rig's own mesh:
the mouth and the eyes are the openings of the skin (boundary loops), told apart in the face's frame
(`rigs.frontal_camera`): the mouth straddles the symmetry plane at the front, the eyes are the largest
opening on each side above it. EO zips the upper and lower halves of an eye's loop together; ES zips two
chains of skin vertices sampled on an ellipse around the eye, 1.6 eye half-widths across. A rig whose eyes
or mouth are closed (no opening) has no such characteristic; its lip contour then falls back to the
``upper_lip`` and ``lower_lip`` regions where the rig has them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

#: Eye-socket ellipse: half-axes in eye half-widths across and up, and the number of samples.
_SOCKET_ACROSS, _SOCKET_UP, _SOCKET_SAMPLES = 1.6, 1.3, 16
#: An opening wider than this share of the face is the border of the mesh, not a feature.
_BORDER_SHARE = 0.6
#: Areas below this fraction of a triangle's rest area count as zero in the ratio of eq. 15.
_AREA_FLOOR = 1e-12


@dataclass(frozen=True)
class Features:
    """Supplementary triangles and contour vertices of one template (fine vertex indices).

    Attributes
    ----------
    eye_openings : (E, 3) int array
        EO triangles between the upper and lower eyelids.
    eye_sockets : (S, 3) int array
        ES triangles between the upper and lower boundaries of the eye sockets.
    lip_contour : (L,) int array
        LC vertices.
    eye_centres, mouth_centre : arrays or None
        Positions on the template neutral, for the regions of the tissue thickness.
    """

    eye_openings: np.ndarray
    eye_sockets: np.ndarray
    lip_contour: np.ndarray
    eye_centres: np.ndarray | None
    mouth_centre: np.ndarray | None

    @property
    def area_triangles(self) -> np.ndarray:
        """EO and ES triangles stacked (the area terms of eqs. A.2-A.3)."""
        return np.concatenate((self.eye_openings, self.eye_sockets)).reshape(-1, 3)


def boundary_loops(triangles: np.ndarray) -> list[np.ndarray]:
    """Closed chains of boundary edges (edges of one triangle only), each as an ordered vertex array."""
    heads = triangles.ravel()
    tails = np.roll(triangles, -1, axis=1).ravel()
    keys = np.minimum(heads, tails).astype(np.int64) << 32 | np.maximum(heads, tails)
    unique, counts = np.unique(keys, return_counts=True)
    single = np.isin(keys, unique[counts == 1])
    successor: dict[int, list[int]] = {}
    for head, tail in zip(heads[single].tolist(), tails[single].tolist(), strict=True):
        successor.setdefault(head, []).append(tail)
    loops = []
    while successor:
        start = next(iter(successor))
        loop = [start]
        current = start
        while True:
            following = successor.get(current)
            if not following:
                break
            nxt = following.pop()
            if not following:
                del successor[current]
            if nxt == start:
                break
            loop.append(nxt)
            current = nxt
        if len(loop) >= 3:
            loops.append(np.array(loop))
    return loops


def zip_chains(upper: np.ndarray, lower: np.ndarray, across: np.ndarray) -> np.ndarray:
    """Triangles between two chains that share their end vertices, advancing along ``across``.

    Parameters
    ----------
    upper, lower : int arrays
        Vertex chains, each ordered by ``across`` and starting and ending at the same two corners.
    across : (N,) array
        The coordinate along the chains (the face's right axis).

    Returns
    -------
    (F, 3) int array; triangles with a repeated vertex are left out.
    """
    found = []
    i = j = 0
    while i < len(upper) - 1 or j < len(lower) - 1:
        step_upper = j == len(lower) - 1 or (
            i < len(upper) - 1 and across[upper[i + 1]] <= across[lower[j + 1]]
        )
        if step_upper:
            triangle = (upper[i], upper[i + 1], lower[j])
            i += 1
        else:
            triangle = (upper[i], lower[j], lower[j + 1])
            j += 1
        if len(set(triangle)) == 3:
            found.append(triangle)
    return np.array(found, dtype=np.intp).reshape(-1, 3)


def _split(loop: np.ndarray, across: np.ndarray, up: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Upper and lower halves of a loop between its two extreme vertices across, each ordered across."""
    first, last = int(np.argmin(across[loop])), int(np.argmax(across[loop]))
    rolled = np.roll(loop, -first)
    cut = (last - first) % len(loop)
    one, other = rolled[: cut + 1], np.r_[rolled[cut:], rolled[:1]][::-1]
    if up[one].mean() < up[other].mean():
        one, other = other, one
    return one, other


def find_features(
    neutral: np.ndarray,
    triangles: np.ndarray,
    skin: np.ndarray,
    camera: np.ndarray,
    regions: dict[str, np.ndarray] | None = None,
) -> Features:
    """The EO and ES triangles and the LC vertices of a face mesh (Wagner et al. 2024, Fig. 4).

    Parameters
    ----------
    neutral : (N, 3) array
    triangles : (T, 3) int array
    skin : (N,) bool array
        Vertices of the skin (the simulated surface).
    camera : (3, 3) array
        Rows right, up, towards the viewer (`rigs.frontal_camera`).
    regions : dict, optional
        The rig's named vertex regions; ``upper_lip`` and ``lower_lip`` give the lip contour when the
        mouth has no opening.

    Returns
    -------
    Features
        Empty arrays for what the mesh does not show.
    """
    local = (neutral - neutral[skin].mean(axis=0)) @ camera.T
    across, up, depth = local[:, 0], local[:, 1], local[:, 2]
    width = float(np.ptp(across[skin])) or 1.0
    loops = [loop for loop in boundary_loops(triangles[skin[triangles].all(axis=1)])]
    loops = [loop for loop in loops if np.ptp(across[loop]) < _BORDER_SHARE * width]
    mouth = None
    straddling = [loop for loop in loops if across[loop].min() < 0 < across[loop].max()]
    if straddling:
        mouth = max(straddling, key=lambda loop: depth[loop].mean())
    eyes = []
    above = up[mouth].mean() if mouth is not None else -np.inf
    for sign in (1.0, -1.0):
        side = [
            loop for loop in loops if np.all(sign * across[loop] > 0.05 * width) and up[loop].mean() > above
        ]
        if side:
            eyes.append(max(side, key=lambda loop: float(np.ptp(across[loop]))))
    tree = cKDTree(neutral[skin])
    skin_index = np.flatnonzero(skin)
    openings, sockets, centres = [], [], []
    for loop in eyes:
        upper, lower = _split(loop, across, up)
        openings.append(zip_chains(upper, lower, across))
        centre = neutral[loop].mean(axis=0)
        centres.append(centre)
        half = 0.5 * float(np.ptp(across[loop]))
        angles = np.linspace(0.0, 2.0 * np.pi, 2 * _SOCKET_SAMPLES, endpoint=False)
        points = (
            centre
            + np.outer(_SOCKET_ACROSS * half * np.cos(angles), camera[0])
            + np.outer(_SOCKET_UP * half * np.sin(angles), camera[1])
        )
        ring = skin_index[tree.query(points)[1]]
        top = _dedupe(ring[: _SOCKET_SAMPLES + 1][::-1])
        bottom = _dedupe(np.r_[ring[_SOCKET_SAMPLES:], ring[:1]])
        if top[0] == bottom[0] and top[-1] == bottom[-1] and len(set(top) | set(bottom)) >= 3:
            sockets.append(zip_chains(top, bottom, across))
    if mouth is not None:
        contour = np.sort(mouth)
    elif regions and "upper_lip" in regions and "lower_lip" in regions:
        contour = np.union1d(regions["upper_lip"], regions["lower_lip"])
    else:
        contour = np.zeros(0, dtype=np.intp)
    return Features(
        eye_openings=np.concatenate(openings).astype(np.intp) if openings else np.zeros((0, 3), np.intp),
        eye_sockets=np.concatenate(sockets).astype(np.intp) if sockets else np.zeros((0, 3), np.intp),
        lip_contour=contour.astype(np.intp),
        eye_centres=np.array(centres) if centres else None,
        mouth_centre=neutral[mouth].mean(axis=0) if mouth is not None else None,
    )


def _dedupe(chain: np.ndarray) -> np.ndarray:
    """The chain without consecutive repeats."""
    keep = np.r_[True, chain[1:] != chain[:-1]]
    return chain[keep]


def triangle_areas(positions: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Areas of ``triangles`` on ``(..., N, 3)`` positions, as ``(..., F)``."""
    corners = positions[..., triangles, :]
    cross = np.cross(corners[..., 1, :] - corners[..., 0, :], corners[..., 2, :] - corners[..., 0, :])
    return 0.5 * np.linalg.norm(cross, axis=-1)


def area_ratios(features: Features, neutral: np.ndarray, shapes: np.ndarray) -> np.ndarray:
    """``A(S_i, f) / A(S, f)`` of every EO and ES triangle f (eq. 15, ``F_eo`` and ``F_es``).

    The retargeted triangle's area is its area on the target neutral times this ratio, so the eyes
    open and close by the same relative amount on both characters.

    Parameters
    ----------
    features : Features
    neutral : (N, 3) array
        The source neutral S.
    shapes : (B, N, 3) array
        Source expressions as absolute positions.

    Returns
    -------
    (B, F) array; 1 on triangles of zero rest area.
    """
    triangles = features.area_triangles
    rest = triangle_areas(neutral, triangles)
    moved = triangle_areas(shapes, triangles)
    valid = rest > _AREA_FLOOR * max(float(rest.max(initial=0.0)), np.finfo(float).tiny)
    return np.where(valid, moved / np.where(valid, rest, 1.0), 1.0)


def similarity(source: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Scale and rotation of the similarity that best maps ``source`` onto ``target`` (eq. 17).

    Umeyama's closed form, batched.

    Parameters
    ----------
    source, target : (B, L, 3) arrays
        The lip contour of the source expression and of its deformation transfer.

    Returns
    -------
    (B,) scales and (B, 3, 3) proper rotations.
    """
    centred = source - source.mean(axis=1, keepdims=True)
    covariance = np.swapaxes(target - target.mean(axis=1, keepdims=True), 1, 2) @ centred / source.shape[1]
    left, singular, right = np.linalg.svd(covariance)
    sign = np.sign(np.linalg.det(left @ right))
    sign[sign == 0] = 1.0
    flip = np.ones_like(singular)
    flip[:, 2] = sign
    rotation = (left * flip[:, None, :]) @ right
    variance = np.mean(np.sum(centred**2, axis=2), axis=1)
    scale = np.where(
        variance > 0, np.sum(singular * flip, axis=1) / np.where(variance > 0, variance, 1.0), 1.0
    )
    return scale, rotation
