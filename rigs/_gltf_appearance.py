"""The texture coordinates, normals and materials of the glTF primitives read, checked and gathered into the
rig's `rigs._gltf_surface.GltfSurface`: the part of the glTF reader (`rigs._gltf`) that is about how the
mesh looks rather than where its vertices are."""

from __future__ import annotations

import warnings

import numpy as np

from rigs._gltf_buffers import Buffers
from rigs._gltf_document import Document, numbers
from rigs._gltf_surface import GltfSurface, unit_rows
from rigs._rig import RigError, RigWarning


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
            unit_rows(normal) if normal is not None else np.full((n, 3), np.nan)
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
