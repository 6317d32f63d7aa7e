"""What a glTF mesh holds besides positions (texture coordinates, normals, materials), kept to write the rig
with it."""

from __future__ import annotations

import warnings
from dataclasses import dataclass, replace

import numpy as np

from rigs._gltf_buffers import Buffers
from rigs._gltf_document import Document, numbers
from rigs._rig import RigError, RigWarning


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
        return replace(self, normals=_unit(self.normals @ (sign * cofactor).T))

    def welded(self, vertex_map: np.ndarray, kept: np.ndarray) -> GltfSurface:
        """The surface after `weld_seams`: ``vertex_map`` of its glTF vertices, its triangles ``kept``."""
        return replace(
            self,
            corners=self.corners[kept],
            vertex_map=vertex_map[self.vertex_map],
            material=self.material[kept],
        )


def _unit(vectors: np.ndarray) -> np.ndarray:
    """Rows scaled to unit length; zero rows stay zero and NaN rows (no normal) NaN."""
    lengths = np.linalg.norm(vectors, axis=1, keepdims=True)
    return vectors / np.where(lengths > 0, lengths, 1.0)


def surface_of(
    document: Document,
    looks: list[tuple[np.ndarray | None, np.ndarray | None]],
    counts: list[int],
    materials: list[int | None],
    sizes: list[int],
    triangles: np.ndarray,
) -> GltfSurface | None:
    """The `GltfSurface` of the primitives read: the texture coordinates and normals (`appearance`) of each
    vertex set read, with its vertex count, and the material of each primitive, with its triangle count;
    None when there are no texture coordinates, normals or materials."""
    if all(part is None for look in looks for part in look) and all(index is None for index in materials):
        return None
    uvs = np.concatenate(
        [uv if uv is not None else np.full((n, 2), np.nan) for (uv, _), n in zip(looks, counts, strict=True)]
    )
    normals = np.concatenate(
        [
            _unit(normal) if normal is not None else np.full((n, 3), np.nan)
            for (_, normal), n in zip(looks, counts, strict=True)
        ]
    )
    used = list(dict.fromkeys(index for index in materials if index is not None))
    material = np.concatenate(
        [
            np.full(size, -1 if index is None else used.index(index), dtype=np.int64)
            for index, size in zip(materials, sizes, strict=True)
        ]
    )
    return GltfSurface(
        corners=triangles,
        vertex_map=np.arange(len(uvs)),
        uvs=uvs,
        normals=normals,
        material=material,
        materials=_materials(document, used),
    )


def appearance(
    document: Document, buffers: Buffers, primitive: dict, label: str, n_vertices: int
) -> tuple[np.ndarray | None, np.ndarray | None, int | None]:
    """``TEXCOORD_0`` (V, 2), ``NORMAL`` (V, 3) and the material index of a primitive, each None when
    absent or malformed (a `RigWarning` says which was left out and why)."""
    attributes = document.field(primitive, "attributes", dict, label, default={})
    values: list[np.ndarray | None] = []
    for name, kind in (("TEXCOORD_0", "VEC2"), ("NORMAL", "VEC3")):
        index = attributes.get(name)
        try:
            read = (
                None if index is None else buffers.accessor(index, kind, f"{label} {name}", count=n_vertices)
            )
            if read is not None and not np.isfinite(read).all():
                raise RigError(f"{label} {name}: holds a value that is not finite")
        except RigError as error:
            warnings.warn(f"{error}; {name} left out", RigWarning, stacklevel=4)
            read = None
        values.append(read)
    index = primitive.get("material")
    if index is not None:
        try:
            document.item("materials", index, label)
        except RigError as error:
            warnings.warn(f"{error}; left out", RigWarning, stacklevel=4)
            index = None
    return values[0], values[1], index


#: Characters of a material name kept in an OBJ or MTL file (whitespace would end the name).
_MATERIAL_NAME = 120


def _materials(document: Document, indices: list[int]) -> tuple[tuple[str, tuple[float, float, float]], ...]:
    """Name and base colour (``pbrMetallicRoughness.baseColorFactor``, default white) of each material of
    ``indices``; names made one word and unique (``material_<i>`` for a material without one)."""
    entries: list[tuple[str, tuple[float, float, float]]] = []
    for index in indices:
        material = document.item("materials", index, f"{document.source}: material")
        name = material.get("name")
        word = "_".join(name.split())[:_MATERIAL_NAME] if isinstance(name, str) else ""
        word = word if word and word not in {entry[0] for entry in entries} else f"material_{index}"
        entries.append((word, _base_colour(material, f"{document.source}: material {index}")))
    return tuple(entries)


def _base_colour(material: dict, label: str) -> tuple[float, float, float]:
    pbr = material.get("pbrMetallicRoughness")
    factor = pbr.get("baseColorFactor") if isinstance(pbr, dict) else None
    if factor is None:
        return (1.0, 1.0, 1.0)
    try:
        red, green, blue, _ = np.clip(numbers(factor, 4, f"{label} baseColorFactor"), 0.0, 1.0)
    except RigError as error:
        warnings.warn(f"{error}; white instead", RigWarning, stacklevel=5)
        return (1.0, 1.0, 1.0)
    return (float(red), float(green), float(blue))
