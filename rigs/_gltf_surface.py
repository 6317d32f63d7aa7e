"""What a glTF mesh holds besides positions (texture coordinates, normals, materials), kept to write the rig
with it.

A plain record on numpy alone, so that `rigs.Surface`, which holds one, depends on no part of the glTF
reader; the reader fills it (`rigs._gltf_appearance`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np


@dataclass(frozen=True, eq=False)
class GltfSurface:
    """What a glTF mesh holds besides positions, per glTF vertex, to write the rig with it (e.g. as OBJ).

    glTF stores one texture coordinate and one normal per vertex, so exporters split vertices along UV
    and normal seams; after welding (``load_gltf(weld=True)``) one rig vertex stands for several glTF
    vertices, which keep their own texture coordinates and normals here.

    Attributes
    ----------
    corners : (T, 3) int array
        The glTF vertices of each triangle of the rig, in the rig's triangle order.
    vertex_map : (V,) int array
        The rig vertex of each glTF vertex (``arange(V)`` without welding).
    uvs : (V, 2) float array
        ``TEXCOORD_0`` as glTF stores it (origin at the image's top left, v downwards); NaN rows for the
        vertices of primitives without it.
    normals : (V, 3) float array
        ``NORMAL`` of the neutral, unit length, in the rig's frame (turned by the node transform the
        positions had); NaN rows for the vertices of primitives without it.
    material : (T,) int array
        Index into ``materials`` of each triangle's material, -1 for none.
    materials : tuple of (name, RGB)
        Each material's name (``material_<i>`` when it has none) and base colour factor.
    """

    corners: np.ndarray
    vertex_map: np.ndarray
    uvs: np.ndarray
    normals: np.ndarray
    material: np.ndarray
    materials: tuple[tuple[str, tuple[float, float, float]], ...]

    def transformed(self, matrix: np.ndarray) -> GltfSurface:
        """The surface of the positions turned by the (3, 3) ``matrix``: normals by its cofactor matrix
        (the inverse transpose up to a positive factor, defined also for a singular matrix)."""
        a, b, c = np.asarray(matrix, dtype=np.float64).T
        cofactor = np.stack([np.cross(b, c), np.cross(c, a), np.cross(a, b)], axis=1)
        sign = np.sign(np.linalg.det(matrix)) or 1.0
        return replace(self, normals=unit_rows(self.normals @ (sign * cofactor).T))

    def welded(self, vertex_map: np.ndarray, kept: np.ndarray) -> GltfSurface:
        """The surface after `weld_seams`: ``vertex_map`` of its glTF vertices, its triangles ``kept``."""
        return replace(
            self,
            corners=self.corners[kept],
            vertex_map=vertex_map[self.vertex_map],
            material=self.material[kept],
        )


def unit_rows(vectors: np.ndarray) -> np.ndarray:
    """Rows scaled to unit length; zero rows stay zero and NaN rows (no normal) NaN."""
    lengths = np.linalg.norm(vectors, axis=1, keepdims=True)
    return vectors / np.where(lengths > 0, lengths, 1.0)
