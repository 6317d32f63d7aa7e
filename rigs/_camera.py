"""A frontal camera found from the face itself: how to look at a rig so that its face is seen from the front.

The viewer's right axis is the normal of the face's left/right symmetry plane (the plane of the mirror map,
Carrigan et al. 2020, sec. 4.4.1); the view direction lies in that plane and is where the moving part of
the face looks: the area-weighted normals of the triangles the blendshapes move, each weighted by how far
its corners move, projected into the plane. Closed parts (eyeballs, teeth, the back of a head) cancel out
of that sum, and the moving skin of the face dominates it, so full heads and face masks alike are seen
from the front, not from above as the mean normal of a whole head would see them.

"Up" is the line from the mouth and jaw shapes to the brow and eye shapes where the names tell them
(vertical within a few degrees on the ARKit-style rigs, where the moving normals lean 10-20 degrees
down, towards the chin); without such names it is across the view direction, signed to the positive side
of its nearest world axis. Shapes named for the character's left (``_L``, ``Left``) must lie on the
viewer's right, else the camera is behind the face (a mesh with inverted normals) and turns round.
"""

from __future__ import annotations

import re

import numpy as np

from rigs._mirror import mirror_map
from rigs._names import side_of
from rigs._rig import Rig, vector_lengths

#: Names of shapes of the upper face and of the lower face, for the sign of "up".
_UPPER = re.compile(r"brow|eye|lid|forehead", re.IGNORECASE)
_LOWER = re.compile(r"mouth|jaw|lip|chin|tongue", re.IGNORECASE)
#: Largest number of vertices the symmetry plane is fitted on (a sample of the mesh).
_PLANE_SAMPLE = 20000


def frontal_camera(rig: Rig) -> np.ndarray:
    """Orthonormal rows (right, up, towards the viewer) of a front view of ``rig``'s face.

    The right axis is the normal of the left/right symmetry plane of the mirror map (Carrigan et al.
    2020, sec. 4.4.1); the view direction is where the moving part of the face looks, in that plane.

    Parameters
    ----------
    rig : Rig

    Returns
    -------
    (3, 3) float array; ``right x up = towards``. Project positions with ``positions @ camera.T``:
    columns 0 and 1 are the picture's x (to the viewer's right) and y (up), column 2 the nearness.

    Examples
    --------
    >>> import rigs
    >>> camera = rigs.frontal_camera(rigs.generate("tiny"))
    >>> bool(np.allclose(camera @ camera.T, np.eye(3)))
    True

    Notes
    -----
    One mirror map of the neutral (`rigs.mirror_map`, O(N log N)) and one pass over the deltas (O(K N)).
    """
    neutral = np.asarray(rig.neutral, dtype=np.float64)
    motion = vector_lengths(rig.deltas) if rig.n_shapes else np.zeros((0, len(neutral)))
    moved = motion.max(axis=0) if len(motion) else np.zeros(len(neutral))
    right = _symmetry_normal(neutral, rig.triangles)
    facing = _facing(neutral, rig.triangles, moved, right)
    up = _vertical(rig.names, motion, neutral, right)
    if up is None:  # no brow and mouth names: up is across the facing direction, signed by the world axes
        up = np.cross(facing, right)
        up = up if up[int(np.argmax(np.abs(up)))] > 0 else -up
    towards = np.cross(right, up)
    if towards @ facing < 0:
        towards, right = -towards, -right
    if _side_sign(rig.names, motion, neutral, right) < 0:  # seen from behind: the left is on the left
        towards, right = -towards, -right
    return np.stack([right, up, towards])


def three_quarter_camera(camera: np.ndarray, degrees: float = 35.0) -> np.ndarray:
    """``camera`` (rows right, up, towards the viewer) turned about its up axis by ``degrees``, towards
    the character's left side, which then faces the viewer more."""
    right, up, towards = camera
    angle = np.radians(degrees)
    turned = np.cos(angle) * towards + np.sin(angle) * right
    return np.stack([np.cross(up, turned), up, turned])


def _symmetry_normal(neutral: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Unit normal of the left/right symmetry plane: principal direction of the mirror map's chords
    (the world x axis for a mesh without a mirror)."""
    mirror = mirror_map(neutral, triangles=triangles if len(triangles) else None)
    source = np.flatnonzero(mirror >= 0)
    chords = neutral[source] - neutral[mirror[source]]
    chords = chords[np.einsum("ij,ij->i", chords, chords) > 0]
    if len(chords) < 3:
        return np.array([1.0, 0.0, 0.0])
    _, _, directions = np.linalg.svd(chords[:: max(1, len(chords) // _PLANE_SAMPLE)], full_matrices=False)
    normal = directions[0]
    return normal if normal[int(np.argmax(np.abs(normal)))] > 0 else -normal


def _facing(neutral: np.ndarray, triangles: np.ndarray, moved: np.ndarray, right: np.ndarray) -> np.ndarray:
    """The direction the moving part of the face looks, in the symmetry plane (unit)."""
    corners = neutral[triangles]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])  # area-weighted
    weights = moved[triangles].mean(axis=1) if len(triangles) else np.zeros(0)
    for weighting in (weights, np.ones(len(triangles))):  # the moving part, else the whole mesh
        facing = (normals * weighting[:, None]).sum(axis=0)
        facing -= (facing @ right) * right
        total = (np.linalg.norm(normals, axis=1) * weighting).sum()
        if total > 0 and np.linalg.norm(facing) > 0.05 * total:
            return facing / np.linalg.norm(facing)
    fallback = np.array([0.0, 0.0, 1.0]) if abs(right[2]) < 0.9 else np.array([0.0, 1.0, 0.0])
    fallback -= (fallback @ right) * right
    return fallback / np.linalg.norm(fallback)


def _region_centre(chosen: list[int], motion: np.ndarray, neutral: np.ndarray) -> np.ndarray | None:
    """Motion-weighted centre of the vertices the ``chosen`` shapes move, or None."""
    if not chosen:
        return None
    weights = motion[chosen].sum(axis=0)
    total = weights.sum()
    return None if total <= 0 else (weights @ neutral) / total


def _vertical(
    names: tuple[str, ...], motion: np.ndarray, neutral: np.ndarray, right: np.ndarray
) -> np.ndarray | None:
    """Unit direction from the mouth and jaw shapes up to the brow and eye shapes, in the symmetry plane
    (the face's vertical: within a few degrees on every ARKit-style rig), or None without such names."""
    upper = [k for k, name in enumerate(names) if _UPPER.search(name) and not _LOWER.search(name)]
    lower = [k for k, name in enumerate(names) if _LOWER.search(name) and not _UPPER.search(name)]
    top, bottom = _region_centre(upper, motion, neutral), _region_centre(lower, motion, neutral)
    if top is None or bottom is None:
        return None
    vertical = top - bottom
    vertical -= (vertical @ right) * right
    length = np.linalg.norm(vertical)
    return None if length <= 1e-9 * np.linalg.norm(np.ptp(neutral, axis=0)) else vertical / length


def _side_sign(names: tuple[str, ...], motion: np.ndarray, neutral: np.ndarray, right: np.ndarray) -> float:
    """+1 unless the shapes named for the character's left lie on the viewer's left (seen from behind)."""
    left = [k for k, name in enumerate(names) if side_of(name) == "L"]
    right_side = [k for k, name in enumerate(names) if side_of(name) == "R"]
    a, b = _region_centre(left, motion, neutral), _region_centre(right_side, motion, neutral)
    if a is None or b is None or (a - b) @ right == 0:
        return 1.0
    return float(np.sign((a - b) @ right))
