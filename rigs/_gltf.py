"""glTF 2.0 (``.gltf`` / ``.glb``) morph targets as a rig.

One mesh becomes the rig: its primitive's ``POSITION`` is the neutral and each morph target's ``POSITION``
is a blendshape delta (glTF morph targets are already displacements). Exporters write one primitive per
material (skin, teeth, eyelashes), all with the same morph targets; such primitives are read as one mesh.
Target names come from ``primitive.extras.targetNames`` when present, else ``mesh.extras.targetNames``
(the de-facto convention of Blender and most exporters), else ``target_<i>``. What the mesh holds besides
positions, its texture coordinates (``TEXCOORD_0``), normals (``NORMAL``) and each primitive's material, is
kept in ``meta["gltf_surface"]`` (`GltfSurface`), so that the rig can be written out with them.

The file is untrusted. Its JSON is read with :mod:`json` and every field the reader uses is checked for
its type and range (pygltflib's decoder coerces mistyped fields, turning a ``bufferView`` of 1.5 into 1,
so it is not used for reading); the GLB container is checked chunk by chunk. Buffers are read only from
the GLB binary chunk, from valid ``data:`` URIs, or from regular files inside the glTF's folder (see
:mod:`rigs._safe`); an accessor is sized against the bytes its buffer view really holds before anything
is allocated, and all morph targets together against what the files can describe
(:func:`rigs._safe.check_budget`). The node hierarchy must be a forest (no cycles, one parent per node).
"""

from __future__ import annotations

import base64
import binascii
import json
import os
import struct
import warnings
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any
from urllib.parse import unquote, unquote_to_bytes, urlsplit

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from rigs._rig import Rig, RigError, RigWarning
from rigs._safe import check_budget, named_path, read_bytes

_COMPONENT_TYPES = {
    5120: np.dtype("<i1"),
    5121: np.dtype("<u1"),
    5122: np.dtype("<i2"),
    5123: np.dtype("<u2"),
    5125: np.dtype("<u4"),
    5126: np.dtype("<f4"),
}
#: Component types an index accessor may have (glTF 2.0 sec. 3.7.2.1: unsigned integers only).
_INDEX_TYPES = {key: _COMPONENT_TYPES[key] for key in (5121, 5123, 5125)}
_WIDTHS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}
_MODES = {
    0: "POINTS",
    1: "LINES",
    2: "LINE_LOOP",
    3: "LINE_STRIP",
    4: "TRIANGLES",
    5: "TRIANGLE_STRIP",
    6: "TRIANGLE_FAN",
}
_COMPRESSIONS = {
    "KHR_draco_mesh_compression": "Draco; decode it first (e.g. `gltf-transform decompress in.glb out.glb`)"
    " or install DracoPy and convert",
    "EXT_meshopt_compression": "meshoptimizer; install a decoder (pip install almeshopt) or write it "
    "uncompressed first: `gltfpack -i in.glb -o out.glb -noq`",
}
#: meshopt filters a decoded view may declare; the others (OCTAHEDRAL, QUATERNION, EXPONENTIAL) pack
#: normals, rotations and exponents, which are not rig data.
_MESHOPT_FILTERS = ("NONE",)
#: A meshopt view decodes to at most this many times its compressed bytes (plus `_MESHOPT_SLACK`).
_MESHOPT_RATIO = 256
_MESHOPT_SLACK = 2**20
#: Required extensions this reader implements (quantised positions are dequantised, see `_dequantise`).
_IMPLEMENTED = {"KHR_mesh_quantization", "EXT_meshopt_compression"}
#: Required extensions that change only how the mesh looks, never its positions: safe to ignore.
_APPEARANCE_PREFIXES = ("KHR_materials_", "KHR_texture_", "EXT_texture_", "KHR_lights_", "EXT_lights_")
_GLB_MAGIC = b"glTF"
_JSON_CHUNK, _BIN_CHUNK = b"JSON", b"BIN\x00"


def load_gltf(
    path: str | Path,
    *,
    mesh: str | int | None = None,
    primitive: int | None = None,
    weld: bool = False,
    weld_tolerance: float = 1e-6,
    transform: bool = True,
) -> Rig:
    """A rig from the morph targets of one glTF 2.0 mesh (its primitives with the same targets).

    Parameters
    ----------
    path : path
        A ``.gltf`` (buffers as files in its folder or as data URIs) or ``.glb`` file.
    mesh : str or int, optional
        Name or index of the mesh; default: the primitive with the most morph targets in the file
        (ties: more vertices, then file order). Other meshes with morph targets are named in a
        `RigWarning`.
    primitive : int, optional
        Index of the one primitive to read within the chosen mesh; default: its primitive with the most
        targets, together with every other triangle primitive of the mesh (one primitive per material,
        as exporters write them), vertices in primitive order. Those must have the same morph targets
        (count and names), as glTF requires; primitives of points or lines are left out with a
        `RigWarning`.
    weld : bool
        Merge vertices that exporters split along UV or normal seams: vertices closer than
        ``weld_tolerance`` whose displacements also agree within it in every target become one.
    weld_tolerance : float
        Relative to the neutral's bounding-box diagonal.
    transform : bool
        Apply the world transform of the first node that instances the mesh (so positions are what the
        scene shows; this also dequantises ``KHR_mesh_quantization`` data). Skinned meshes are left in
        mesh space, as the glTF specification says.

    Returns
    -------
    Rig with ``meta["units"] = "m"`` (glTF's unit), ``meta["format"] = "gltf"``, ``meta["primitives"]``
    (the primitive indices read), ``meta["gltf_surface"]`` (a `GltfSurface`) when a primitive has texture
    coordinates, normals or a material, and, after welding,
    ``meta["weld"] = {"merged": count, "vertex_map": (V,) rig vertex of each glTF vertex}``.

    Raises
    ------
    RigError
        One line naming the file (the mesh, primitive and target where there is one) and the problem:
        not a regular file, not glTF 2.0 (or a malformed GLB container), a field of the wrong type or
        out of range, no morph targets, unknown mesh, a compressed primitive (naming the extension and
        how to decode it), another required extension it does not implement, a buffer URI that is
        absolute, leaves the folder, names a scheme or is a malformed ``data:`` URI, a missing buffer,
        an accessor of the wrong type, past the end of its buffer view, or with a ``byteStride``
        smaller than its elements, index accessors that are not unsigned integers, sibling primitives
        with other morph targets, duplicate target names, a cycle in the node hierarchy, or arrays
        larger than the file can describe.

    Warns
    -----
    RigWarning
        Naming the other meshes with morph targets when ``mesh`` is not given (only one is read), the
        primitives of points or lines left out of the mesh, and texture coordinates, normals or materials
        left out because they are malformed (the positions are read all the same).
    """
    path = Path(path)
    source = str(path)
    document, blob, size = _open(path)
    _check_extensions(document, source)
    mesh_index, primitive_index = _choose(document, mesh, primitive, source)
    chosen_mesh = document.items("meshes")[mesh_index]
    primitives = document.field(chosen_mesh, "primitives", list, _label(source, chosen_mesh, mesh_index))
    chosen = primitives[primitive_index]
    label = _primitive_label(source, chosen_mesh, mesh_index, primitive_index)
    names = _target_names(document, chosen_mesh, chosen, len(_targets(document, chosen, label)), label)
    if primitive is not None:
        members = [primitive_index]
    else:
        members = _same_targets(document, chosen_mesh, mesh_index, primitive_index, names, source)
    if mesh is None:
        _warn_other_meshes(document, mesh_index, source)
    buffers = _Buffers(document, path, blob, size)
    labels = [_primitive_label(source, chosen_mesh, mesh_index, j) for j in members]
    counts = [_vertex_count(document, primitives[j], label) for j, label in zip(members, labels, strict=True)]
    for j, label in zip(members, labels, strict=True):
        buffers.load_for(_primitive_accessors(document, primitives[j], label), label)
    check_budget(
        source,
        f"{len(names)} morph targets of {sum(counts)} vertices",
        len(names) * sum(counts) * 3 * 8,
        buffers.source_bytes,
    )
    parts = [
        _read_primitive(document, buffers, primitives[j], label, count)
        for j, label, count in zip(members, labels, counts, strict=True)
    ]
    offsets = np.cumsum([0, *counts[:-1]])
    neutral = np.concatenate([part[0] for part in parts])
    deltas = np.concatenate([part[1] for part in parts], axis=1)
    triangles = np.concatenate([part[2] + offset for part, offset in zip(parts, offsets, strict=True)])
    looks = [
        _appearance(document, buffers, primitives[j], label, count)
        for j, label, count in zip(members, labels, counts, strict=True)
    ]

    meta: dict = {
        "source": source,
        "format": "gltf",
        "units": "m",
        "mesh": str(chosen_mesh.get("name") or mesh_index),
        "primitives": members,
    }
    surface = _surface(document, looks, counts, [len(part[2]) for part in parts], triangles)
    parents = _node_parents(document, source)
    if transform:
        matrix, node_name = _world_matrix(document, parents, mesh_index, source)
        if matrix is not None:
            with np.errstate(over="ignore", invalid="ignore"):  # (overflowing positions: `Rig` refuses them)
                neutral = neutral @ matrix[:3, :3].T + matrix[:3, 3]
                deltas = deltas @ matrix[:3, :3].T
            meta["transform"] = f"world matrix of node {node_name!r}"
            if surface is not None:
                surface = surface.transformed(matrix[:3, :3])
    if weld:
        corners = triangles
        neutral, deltas, triangles, vertex_map = weld_seams(neutral, deltas, triangles, weld_tolerance)
        meta["weld"] = {"merged": int(len(vertex_map) - len(neutral)), "vertex_map": vertex_map}
        if surface is not None:
            surface = surface.welded(vertex_map, ~_collapsed(vertex_map[corners]))
    if surface is not None:
        meta["gltf_surface"] = surface
    return Rig(neutral=neutral, deltas=deltas, triangles=triangles, names=names, meta=meta)


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


def _surface(
    document: _Document,
    looks: list[tuple[np.ndarray | None, np.ndarray | None, int | None]],
    counts: list[int],
    sizes: list[int],
    triangles: np.ndarray,
) -> GltfSurface | None:
    """The `GltfSurface` of the primitives read, from each one's `_appearance`, vertex count and
    triangle count; None when none has texture coordinates, normals or a material."""
    if all(part is None for look in looks for part in look):
        return None
    uvs = np.concatenate(
        [
            uv if uv is not None else np.full((n, 2), np.nan)
            for (uv, _, _), n in zip(looks, counts, strict=True)
        ]
    )
    normals = np.concatenate(
        [
            _unit(normal) if normal is not None else np.full((n, 3), np.nan)
            for (_, normal, _), n in zip(looks, counts, strict=True)
        ]
    )
    used = list(dict.fromkeys(index for _, _, index in looks if index is not None))
    material = np.concatenate(
        [
            np.full(size, -1 if index is None else used.index(index), dtype=np.int64)
            for (_, _, index), size in zip(looks, sizes, strict=True)
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


def _appearance(
    document: _Document, buffers: _Buffers, primitive: dict, label: str, n_vertices: int
) -> tuple[np.ndarray | None, np.ndarray | None, int | None]:
    """``TEXCOORD_0`` (V, 2), ``NORMAL`` (V, 3) and the material index of a primitive, each None when
    absent or malformed (a `RigWarning` says which was left out and why)."""
    attributes = _attributes(document, primitive, "attributes", label)
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


def _materials(document: _Document, indices: list[int]) -> tuple[tuple[str, tuple[float, float, float]], ...]:
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
        red, green, blue, _ = np.clip(_numbers(factor, 4, f"{label} baseColorFactor"), 0.0, 1.0)
    except RigError as error:
        warnings.warn(f"{error}; white instead", RigWarning, stacklevel=5)
        return (1.0, 1.0, 1.0)
    return (float(red), float(green), float(blue))


def _collapsed(triangles: np.ndarray) -> np.ndarray:
    """(T,) bool: triangles with two equal corners."""
    return (
        (triangles[:, 0] == triangles[:, 1])
        | (triangles[:, 1] == triangles[:, 2])
        | (triangles[:, 0] == triangles[:, 2])
    )


# -- the document ----------------------------------------------------------------------------------------
class _Document:
    """The glTF JSON with checked access: arrays of objects, typed fields, indices in range."""

    def __init__(self, content: dict, source: str) -> None:
        self.content = content
        self.source = source

    def items(self, name: str) -> list[dict]:
        """The top-level array ``name`` (``[]`` when absent); each element must be an object."""
        values = self.content.get(name, [])
        if not isinstance(values, list) or not all(isinstance(value, dict) for value in values):
            raise RigError(f"{self.source}: '{name}' must be an array of objects")
        return values

    def item(self, name: str, index: Any, label: str) -> dict:
        """Element ``index`` of the top-level array ``name``; `RigError` when it does not exist."""
        values = self.items(name)
        singular = name[:-1]
        if not _is_int(index) or not 0 <= index < len(values):
            raise RigError(f"{label}: {singular} {index!r:.40} does not exist (the file has {len(values)})")
        return values[index]

    def field(self, obj: dict, key: str, kind: type, label: str, default: Any = None) -> Any:
        """``obj[key]`` checked to be a ``kind`` (``default`` when absent)."""
        value = obj.get(key, default)
        if value is default:
            return value
        if kind is int:
            valid = _is_int(value)
        elif kind is bool:
            valid = isinstance(value, bool)
        else:
            valid = isinstance(value, kind)
        if not valid:
            raise RigError(f"{label}: '{key}' must be {_KIND_NAMES[kind]}, got {value!r:.40}")
        return value

    def count(self, obj: dict, key: str, label: str, *, default: int | None = None, minimum: int = 0) -> int:
        """A non-negative integer field (``default`` when absent; required when ``default`` is None)."""
        value = obj.get(key, default)
        if value is None:
            raise RigError(f"{label}: '{key}' is missing")
        if not _is_int(value) or value < minimum:
            raise RigError(f"{label}: '{key}' must be an integer >= {minimum}, got {value!r:.40}")
        return value


_KIND_NAMES = {int: "an integer", str: "a string", list: "an array", dict: "an object", bool: "true or false"}


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _open(path: Path) -> tuple[_Document, memoryview | None, int]:
    """The document, the GLB binary chunk (None for ``.gltf``) and the file's size."""
    data = read_bytes(path)
    blob = None
    text: bytes | memoryview = data
    if data[:4] == _GLB_MAGIC:
        text, blob = _glb_chunks(data, str(path))
    try:
        content = json.loads(bytes(text))
    except (ValueError, RecursionError) as error:  # (JSONDecodeError and UnicodeDecodeError are ValueErrors)
        raise RigError(f"{path}: not a readable glTF 2.0 file ({type(error).__name__}: {error})") from None
    if not isinstance(content, dict):
        raise RigError(f"{path}: not a readable glTF 2.0 file (the JSON is not an object)")
    asset = content.get("asset")
    version = asset.get("version") if isinstance(asset, dict) else None
    if not isinstance(version, str) or not version.startswith("2"):
        raise RigError(f"{path}: not a glTF 2.0 file (asset.version {version!r:.40})")
    return _Document(content, str(path)), blob, len(data)


def _glb_chunks(data: bytes, source: str) -> tuple[memoryview, memoryview | None]:
    """JSON and BIN chunks of a GLB container (glTF 2.0 sec. 4.4), every length checked.

    pygltflib's reader cuts short chunks silently; here a header or chunk that does not fit the file is an
    error. Chunks of other types are skipped, as the specification says.
    """
    if len(data) < 12:
        raise RigError(f"{source}: truncated GLB header ({len(data)} bytes)")
    _, version, length = struct.unpack_from("<4sII", data)
    if version != 2:
        raise RigError(f"{source}: GLB container version {version}, expected 2")
    if length != len(data):
        raise RigError(f"{source}: GLB header says {length} bytes, the file has {len(data)} (truncated?)")
    view = memoryview(data)
    chunks: list[tuple[bytes, memoryview]] = []
    offset = 12
    while offset < length:
        if offset + 8 > length:
            raise RigError(f"{source}: GLB chunk {len(chunks)} has a truncated header at byte {offset}")
        chunk_length, chunk_type = struct.unpack_from("<I4s", data, offset)
        start, end = offset + 8, offset + 8 + chunk_length
        if end > length:
            raise RigError(
                f"{source}: GLB chunk {len(chunks)} of {chunk_length} bytes runs past the end of the file"
            )
        chunks.append((chunk_type, view[start:end]))
        offset = end
    if not chunks or chunks[0][0] != _JSON_CHUNK:
        raise RigError(f"{source}: the first GLB chunk is not JSON")
    binaries = [chunk for kind, chunk in chunks[1:] if kind == _BIN_CHUNK]
    if len(binaries) > 1 or any(kind == _JSON_CHUNK for kind, _ in chunks[1:]):
        raise RigError(f"{source}: a GLB container holds one JSON chunk and at most one BIN chunk")
    return chunks[0][1], (binaries[0] if binaries else None)


def _check_extensions(document: _Document, source: str) -> None:
    required = document.content.get("extensionsRequired", [])
    if not isinstance(required, list) or not all(isinstance(name, str) for name in required):
        raise RigError(f"{source}: 'extensionsRequired' must be an array of extension names")
    for extension, remedy in _COMPRESSIONS.items():
        if extension in required and not (extension == "EXT_meshopt_compression" and _meshopt() is not None):
            raise RigError(f"{source}: compressed with {extension} ({remedy})")
    for extension in required:
        if extension not in _IMPLEMENTED and not extension.startswith(_APPEARANCE_PREFIXES):
            raise RigError(
                f"{source}: requires extension {extension!r:.80}, which this reader does not implement "
                "(it reads KHR_mesh_quantization and ignores material, texture and light extensions)"
            )


# -- meshes and primitives -------------------------------------------------------------------------------
def _label(source: str, mesh: dict, mesh_index: int) -> str:
    return f"{source}: mesh {mesh.get('name') or mesh_index!r:.80}"


def _primitive_label(source: str, mesh: dict, mesh_index: int, primitive_index: int) -> str:
    return f"{_label(source, mesh, mesh_index)} primitive {primitive_index}"


def _attributes(document: _Document, holder: dict, key: str, label: str) -> dict:
    attributes = document.field(holder, key, dict, label, default={})
    return attributes


def _targets(document: _Document, primitive: dict, label: str) -> list[dict]:
    targets = document.field(primitive, "targets", list, label, default=[])
    if not all(isinstance(target, dict) for target in targets):
        raise RigError(f"{label}: every morph target must be an object of attributes")
    return targets


def _mode(document: _Document, primitive: dict, label: str) -> int:
    return document.field(primitive, "mode", int, label, default=4)


def _position_count(document: _Document, primitive: dict) -> int:
    """The POSITION accessor's count when it is well formed, else 0 (for ranking primitives only)."""
    attributes = primitive.get("attributes")
    index = attributes.get("POSITION") if isinstance(attributes, dict) else None
    accessors = document.content.get("accessors")
    if not _is_int(index) or not isinstance(accessors, list) or not 0 <= index < len(accessors):
        return 0
    count = accessors[index].get("count") if isinstance(accessors[index], dict) else None
    return count if _is_int(count) and count > 0 else 0


def _choose(
    document: _Document, mesh: str | int | None, primitive: int | None, source: str
) -> tuple[int, int]:
    meshes = document.items("meshes")
    if not meshes:
        raise RigError(f"{source}: has no meshes")
    if mesh is None:
        candidates = range(len(meshes))
    elif _is_int(mesh):
        if not 0 <= mesh < len(meshes):
            raise RigError(f"{source}: no mesh {mesh} (the file has {len(meshes)})")
        candidates = [mesh]
    else:
        candidates = [i for i, m in enumerate(meshes) if m.get("name") == mesh]
        if not candidates:
            available = ", ".join(repr(m.get("name")) for m in meshes[:8])
            raise RigError(f"{source}: no mesh named {mesh!r} (meshes: {available})")
    options = []
    for i in candidates:
        primitives = document.field(meshes[i], "primitives", list, _label(source, meshes[i], i), default=[])
        if primitive is not None:
            if not 0 <= primitive < len(primitives):
                if mesh is None:
                    continue
                raise RigError(f"{_label(source, meshes[i], i)} has no primitive {primitive}")
            indices = [primitive]
        else:
            indices = range(len(primitives))
        for j in indices:
            p = primitives[j]
            if not isinstance(p, dict):
                raise RigError(f"{_primitive_label(source, meshes[i], i, j)}: is not an object")
            targets = _targets(document, p, _primitive_label(source, meshes[i], i, j))
            options.append((len(targets), _position_count(document, p), -i, -j))
    if not options:
        raise RigError(f"{source}: the chosen mesh has no primitives")
    best = max(options)
    if best[0] == 0:
        raise RigError(f"{source}: no mesh primitive has morph targets")
    return -best[2], -best[3]


def _same_targets(
    document: _Document, mesh: dict, mesh_index: int, chosen: int, names: tuple[str, ...], source: str
) -> list[int]:
    """The triangle primitives of ``mesh``, which must have the chosen one's morph targets (count and names).

    Primitives of points or lines are left out with a `RigWarning`.
    """
    primitives = mesh["primitives"]
    count = len(names)
    members = []
    for j, other in enumerate(primitives):
        label = _primitive_label(source, mesh, mesh_index, j)
        if j == chosen:
            members.append(j)
            continue
        mode = _mode(document, other, label)
        if mode not in (4, 5, 6):
            warnings.warn(
                f"{label}: mode {mode} ({_MODES.get(mode, 'unknown')}) has no triangles; left out",
                RigWarning,
                stacklevel=4,
            )
            continue
        theirs = len(_targets(document, other, label))
        if theirs != count:
            raise RigError(
                f"{label}: has {theirs} morph targets, primitive {chosen} has {count} (glTF gives every "
                "primitive of a mesh the same targets); pass primitive=N to read one primitive"
            )
        if _target_names(document, mesh, other, count, label) != names:
            raise RigError(
                f"{label}: its morph targets are named differently from those of primitive {chosen}; "
                "pass primitive=N to read one primitive"
            )
        members.append(j)
    return members


def _warn_other_meshes(document: _Document, chosen: int, source: str) -> None:
    left_out = []
    for i, mesh in enumerate(document.items("meshes")):
        primitives = mesh.get("primitives")
        if i == chosen or not isinstance(primitives, list):
            continue
        counts = [
            len(p["targets"])
            for p in primitives
            if isinstance(p, dict) and isinstance(p.get("targets"), list)
        ]
        if counts and max(counts) > 0:
            plural = "s" if max(counts) > 1 else ""
            left_out.append(f"{mesh.get('name') or i!r:.80} ({max(counts)} morph target{plural})")
    if left_out:
        warnings.warn(
            f"{source}: only one mesh is read; left out: {', '.join(left_out)} "
            "(pass mesh=NAME to read another)",
            RigWarning,
            stacklevel=4,
        )


def _target_names(
    document: _Document, mesh: dict, primitive: dict, count: int, label: str
) -> tuple[str, ...]:
    names = None
    for holder in (primitive, mesh):
        extras = holder.get("extras")
        if isinstance(extras, dict) and extras.get("targetNames") is not None:
            names = extras["targetNames"]
            break
    if names is None:
        return tuple(f"target_{k}" for k in range(count))
    if not isinstance(names, list) or len(names) != count:
        size = len(names) if isinstance(names, list) else names
        raise RigError(f"{label}: extras.targetNames has {size!r:.40} names for {count} morph targets")
    seen: set[str] = set()
    for name in names:
        if not isinstance(name, str):
            raise RigError(f"{label}: extras.targetNames holds {name!r:.40}, not a name")
        if name in seen:
            raise RigError(f"{label}: duplicate morph target name {name!r} in extras.targetNames")
        seen.add(name)
    return tuple(names)


def _position_index(document: _Document, primitive: dict, label: str) -> int:
    index = _attributes(document, primitive, "attributes", label).get("POSITION")
    if index is None:
        raise RigError(f"{label}: has no POSITION attribute")
    return index


def _vertex_count(document: _Document, primitive: dict, label: str) -> int:
    """The number of vertices of ``primitive``: its POSITION accessor's count, which must be stored data."""
    position = _position_index(document, primitive, label)
    accessor = document.item("accessors", position, f"{label} POSITION")
    draco = "KHR_draco_mesh_compression"
    extensions = primitive.get("extensions")
    if isinstance(extensions, dict) and draco in extensions and accessor.get("bufferView") is None:
        raise RigError(f"{label}: compressed with {draco} ({_COMPRESSIONS[draco]})")
    if accessor.get("bufferView") is None:
        raise RigError(
            f"{label} POSITION: accessor {position} has no bufferView; the neutral positions must be stored"
        )
    return document.count(accessor, "count", f"{label} POSITION: accessor {position}")


def _primitive_accessors(document: _Document, primitive: dict, label: str) -> list[int]:
    """The accessors the reader will decode for ``primitive``: positions, target positions, indices."""
    accessors = [_position_index(document, primitive, label)]
    for k, target in enumerate(_targets(document, primitive, label)):
        if target.get("POSITION") is not None:
            accessors.append(target["POSITION"])
        elif not all(_is_int(value) for value in target.values()):
            raise RigError(f"{label}: target {k} has an attribute that is not an accessor index")
    if primitive.get("indices") is not None:
        accessors.append(primitive["indices"])
    return accessors


def _read_primitive(
    document: _Document, buffers: _Buffers, primitive: dict, label: str, n_vertices: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Neutral positions, target deltas and triangles of one primitive."""
    position = _position_index(document, primitive, label)
    neutral = buffers.accessor(position, "VEC3", f"{label} POSITION", count=n_vertices)
    targets = _targets(document, primitive, label)
    deltas = np.zeros((len(targets), n_vertices, 3))
    for k, target in enumerate(targets):
        index = target.get("POSITION")
        if index is None:
            continue
        accessor = document.item("accessors", index, f"{label} target {k} POSITION")
        elements = document.count(accessor, "count", f"{label} target {k} POSITION: accessor {index}")
        if elements != n_vertices:
            raise RigError(f"{label}: target {k} has {elements} positions for {n_vertices} vertices")
        deltas[k] = buffers.accessor(index, "VEC3", f"{label} target {k} POSITION", count=n_vertices)
    return neutral, deltas, _triangles(document, buffers, primitive, n_vertices, label)


def _triangles(
    document: _Document, buffers: _Buffers, primitive: dict, n_vertices: int, label: str
) -> np.ndarray:
    mode = _mode(document, primitive, label)
    if mode not in (4, 5, 6):
        raise RigError(f"{label}: mode {mode} ({_MODES.get(mode, 'unknown')}) has no triangles")
    if primitive.get("indices") is None:
        corners = np.arange(n_vertices, dtype=np.int64)
    else:
        corners = buffers.accessor(
            primitive["indices"], "SCALAR", f"{label} indices", components=_INDEX_TYPES
        ).astype(np.int64)
    if corners.size and corners.max() >= n_vertices:
        raise RigError(f"{label}: index {int(corners.max())} is past the {n_vertices} vertices")
    if mode == 4:
        if corners.size % 3:
            raise RigError(f"{label}: {corners.size} triangle indices is not a multiple of 3")
        return corners.reshape(-1, 3)
    if corners.size < 3:
        return np.zeros((0, 3), dtype=np.int64)
    steps = np.arange(corners.size - 2)
    if mode == 5:
        odd = steps % 2 == 1
        first = np.where(odd, corners[steps + 1], corners[steps])
        second = np.where(odd, corners[steps], corners[steps + 1])
        return np.stack([first, second, corners[steps + 2]], axis=1)
    return np.stack([np.full(steps.size, corners[0]), corners[steps + 1], corners[steps + 2]], axis=1)


# -- buffers and accessors -------------------------------------------------------------------------------
class _Buffers:
    """Decodes accessors (strided views, sparse substitution, normalised integers) of one glTF file.

    ``source_bytes`` counts the bytes of the glTF file and of the buffer files read so far, the measure
    against which decoded arrays are budgeted.
    """

    def __init__(self, document: _Document, path: Path, blob: memoryview | None, size: int) -> None:
        self.document = document
        self.path = path
        self.blob = blob
        self.source_bytes = size
        self._data: dict[int, bytes | memoryview] = {}

    def buffer(self, index: int, label: str) -> bytes | memoryview:
        buffer = self.document.item("buffers", index, label)
        if index not in self._data:
            self._data[index] = self._load(index, buffer)
        return self._data[index]

    def _load(self, index: int, buffer: dict) -> bytes | memoryview:
        label = f"{self.path}: buffer {index}"
        length = self.document.count(buffer, "byteLength", label, minimum=1)
        uri = self.document.field(buffer, "uri", str, label)
        if uri is None:
            if self.blob is None:
                raise RigError(f"{label} has no URI and the file has no GLB binary chunk")
            if index != 0:
                raise RigError(f"{label} has no URI; only buffer 0 may be the GLB binary chunk")
            data = self.blob
        elif uri.startswith("data:"):
            data = _data_uri(uri, label)
        else:
            location = _uri_path(self.path.parent, uri, label)
            if not os.path.lexists(location):
                raise RigError(f"{label} file {location} is missing")
            try:
                data = read_bytes(location, root=self.path.parent, limit=length, head=True)
            except RigError as error:
                raise RigError(f"{label}: {error}") from None
            self.source_bytes += len(data)
        if len(data) < length:
            raise RigError(
                f"{label} holds {len(data)} bytes, fewer than its byteLength {length} (truncated?)"
            )
        return data

    def load_for(self, accessors: list[int], label: str) -> None:
        """Read every buffer the ``accessors`` refer to (so `source_bytes` counts them)."""
        for index in accessors:
            accessor = self.document.item("accessors", index, label)
            views = [accessor.get("bufferView")]
            sparse = accessor.get("sparse")
            if isinstance(sparse, dict):
                views += [
                    part.get("bufferView")
                    for part in (sparse.get("indices"), sparse.get("values"))
                    if isinstance(part, dict)
                ]
            for view_index in views:
                if view_index is not None:
                    view = self.document.item("bufferViews", view_index, f"{label} accessor {index}")
                    where = f"{label} bufferView {view_index}"
                    compressed = _meshopt_extension(view, where)
                    if compressed is not None and _meshopt() is not None:
                        self.buffer(self.document.count(compressed, "buffer", f"{where} meshopt"), label)
                    else:
                        self.buffer(self.document.count(view, "buffer", where), label)

    def accessor(
        self,
        index: int,
        kind: str,
        label: str,
        *,
        count: int | None = None,
        components: dict[int, np.dtype] = _COMPONENT_TYPES,
    ) -> np.ndarray:
        """The values of accessor ``index``, checked to be ``kind`` of ``components`` and, when ``count``
        is given, to have that many elements (before anything is allocated)."""
        document = self.document
        accessor = document.item("accessors", index, label)
        where = f"{label}: accessor {index}"
        component = accessor.get("componentType")
        if accessor.get("type") != kind or not _is_int(component) or component not in components:
            raise RigError(
                f"{where} is {accessor.get('type')!r:.20} of component type {component!r:.20}, "
                f"expected {kind} of {'/'.join(str(c) for c in components)}"
            )
        dtype, width = components[component], _WIDTHS[kind]
        elements = document.count(accessor, "count", where)
        if count is not None and elements != count:
            raise RigError(f"{where} has {elements} elements, expected {count}")
        normalized = document.field(accessor, "normalized", bool, where, default=False)
        offset = document.count(accessor, "byteOffset", where, default=0)
        view = accessor.get("bufferView")
        sparse = document.field(accessor, "sparse", dict, where)
        if view is None:
            if count is None:
                raise RigError(f"{where} has no bufferView: it holds no data")
            values = np.zeros((elements, width), dtype=dtype)
        else:
            values = self._view(view, offset, elements, width, dtype, label)
        if sparse is not None:
            self._substitute(values, sparse, dtype, where)
        return _dequantise(values, normalized) if kind != "SCALAR" else values.ravel()

    def _substitute(self, values: np.ndarray, sparse: dict, dtype: np.dtype, where: str) -> None:
        document = self.document
        label = f"{where} sparse"
        count = document.count(sparse, "count", label)
        if count == 0:  # (the specification says at least 1; writers do write 0 for an empty target)
            return
        if count > len(values):
            raise RigError(f"{label}: {count} substitutions for {len(values)} elements")
        indices = document.field(sparse, "indices", dict, label)
        replacements = document.field(sparse, "values", dict, label)
        if indices is None or replacements is None:
            raise RigError(f"{label}: needs 'indices' and 'values'")
        index_type = indices.get("componentType")
        if not _is_int(index_type) or index_type not in _INDEX_TYPES:
            raise RigError(f"{label} indices have component type {index_type!r:.20}")
        where_view = document.count(indices, "bufferView", f"{label} indices")
        positions = (
            self._view(
                where_view,
                document.count(indices, "byteOffset", f"{label} indices", default=0),
                count,
                1,
                _INDEX_TYPES[index_type],
                f"{label} indices",
            )
            .ravel()
            .astype(np.int64)
        )
        if positions.max() >= len(values):
            raise RigError(
                f"{label}: index {int(positions.max())} is past the accessor's {len(values)} elements"
            )
        if positions.size > 1 and not (np.diff(positions) > 0).all():
            raise RigError(f"{label}: indices do not strictly increase (an element substituted twice?)")
        values_view = document.count(replacements, "bufferView", f"{label} values")
        values[positions] = self._view(
            values_view,
            document.count(replacements, "byteOffset", f"{label} values", default=0),
            count,
            values.shape[1],
            dtype,
            f"{label} values",
        )

    def _view(
        self, view_index: int, offset: int, count: int, width: int, dtype: np.dtype, label: str
    ) -> np.ndarray:
        document = self.document
        view = document.item("bufferViews", view_index, label)
        where = f"{label} bufferView {view_index}"
        compressed = _meshopt_extension(view, where)
        if compressed is not None and _meshopt() is not None:
            data = self._decode_meshopt(compressed, where)
            view = {"byteLength": len(data), "byteStride": compressed["byteStride"]}
        elif compressed is not None and not self._holds_plain_data(view):
            meshopt = "EXT_meshopt_compression"
            raise RigError(f"{self.path}: compressed with {meshopt} ({_COMPRESSIONS[meshopt]})")
        else:
            data = self.buffer(document.count(view, "buffer", where), where)
        view_offset = document.count(view, "byteOffset", where, default=0)
        view_length = document.count(view, "byteLength", where, minimum=1)
        element = width * dtype.itemsize
        stride = document.count(view, "byteStride", where, default=element)
        if stride < element:
            raise RigError(f"{where}: byteStride {stride} is smaller than the {element}-byte elements")
        start = view_offset + offset
        end = start + (count - 1) * stride + element if count else start
        if end > view_offset + view_length or end > len(data):
            raise RigError(
                f"{label}: reads past the end of bufferView {view_index} ({end} > {len(data)} bytes)"
            )
        if count == 0:
            return np.zeros((0, width), dtype=dtype)
        return np.ndarray(
            (count, width), dtype=dtype, buffer=data, offset=start, strides=(stride, dtype.itemsize)
        ).copy()

    def _decode_meshopt(self, compressed: dict, where: str) -> bytes:
        """The bytes of a meshopt-compressed view (``ATTRIBUTES`` or ``TRIANGLES``, filter ``NONE``)."""
        document = self.document
        label = f"{where} EXT_meshopt_compression"
        count = document.count(compressed, "count", label, minimum=1)
        stride = document.count(compressed, "byteStride", label, minimum=1)
        mode, filter_ = compressed.get("mode"), compressed.get("filter", "NONE")
        hint = "write it uncompressed first: `gltfpack -i in.glb -o out.glb -noq`"
        if mode not in ("ATTRIBUTES", "TRIANGLES") or filter_ not in _MESHOPT_FILTERS:
            raise RigError(
                f"{label}: mode {mode!r:.20} with filter {filter_!r:.20} is not decoded here; {hint}"
            )
        data = self.buffer(document.count(compressed, "buffer", label), label)
        offset = document.count(compressed, "byteOffset", label, default=0)
        length = document.count(compressed, "byteLength", label, minimum=1)
        if offset + length > len(data):
            raise RigError(
                f"{label}: reads past the end of its buffer ({offset + length} > {len(data)} bytes)"
            )
        if count * stride > _MESHOPT_RATIO * length + _MESHOPT_SLACK:
            raise RigError(f"{label}: {count} elements of {stride} bytes cannot come from {length} bytes")
        if mode == "TRIANGLES" and (stride not in (2, 4) or count % 3):
            raise RigError(f"{label}: triangle indices need byteStride 2 or 4 and a count divisible by 3")
        decoder = _meshopt()
        encoded = bytes(data[offset : offset + length])
        try:
            if mode == "TRIANGLES":
                indices = decoder.decode_index_buffer(encoded, count)
                return np.asarray(indices, dtype=np.uint16 if stride == 2 else np.uint32).tobytes()
            return np.asarray(decoder.decode_vertex_buffer(encoded, count, stride, dtype=np.uint8)).tobytes()
        except (RuntimeError, ValueError) as error:
            raise RigError(f"{label}: the compressed data does not decode ({error}); {hint}") from None

    def _holds_plain_data(self, view: dict) -> bool:
        """False when a meshopt-compressed view points at a placeholder ("fallback") buffer without data."""
        buffer = self.document.item("buffers", view.get("buffer"), str(self.path))
        extensions = buffer.get("extensions")
        meshopt = extensions.get("EXT_meshopt_compression") if isinstance(extensions, dict) else None
        return not (isinstance(meshopt, dict) and meshopt.get("fallback", False))


def _meshopt_extension(view: dict, where: str) -> dict | None:
    """The ``EXT_meshopt_compression`` object of a buffer view, or None."""
    extensions = view.get("extensions")
    compressed = extensions.get("EXT_meshopt_compression") if isinstance(extensions, dict) else None
    if compressed is not None and not isinstance(compressed, dict):
        raise RigError(f"{where}: EXT_meshopt_compression must be an object")
    return compressed


def _meshopt() -> Any | None:
    """The meshoptimizer decoder (the ``almeshopt`` package), or None when it is not installed."""
    try:
        import almeshopt
    except ImportError:
        return None
    return almeshopt


def _uri_path(root: Path, uri: str, label: str) -> Path:
    """The file a relative buffer URI names inside ``root``; refused when it names a scheme or host,
    is absolute, or leaves ``root`` (also when percent-encoded, as ``%2e%2e/``)."""
    try:
        parts = urlsplit(uri)
    except ValueError as error:
        raise RigError(f"{label}: URI {uri!r:.200} is malformed ({error})") from None
    if parts.scheme or parts.netloc:
        raise RigError(
            f"{label}: URI {uri!r:.200} names a scheme or host; only relative file paths inside "
            f"{root} and data: URIs are read"
        )
    return named_path(root, unquote(parts.path), f"{label} URI")


def _data_uri(uri: str, label: str) -> bytes:
    """The bytes of a ``data:`` URI (RFC 2397): base64 when its header ends in ``;base64``, else
    percent-encoded."""
    header, comma, payload = uri[len("data:") :].partition(",")
    if not comma:
        raise RigError(f"{label}: malformed data URI (no ',' before the data)")
    if not header.endswith(";base64"):
        return unquote_to_bytes(payload)
    try:
        return base64.b64decode(payload, validate=True)
    except (binascii.Error, ValueError) as error:
        raise RigError(f"{label}: malformed base64 in its data URI ({error})") from None


def _dequantise(values: np.ndarray, normalized: bool) -> np.ndarray:
    """Integer accessor values as floats; normalised ones mapped to [-1, 1] or [0, 1] (glTF 2.0 sec. 3.11)."""
    if values.dtype.kind == "f" or not normalized:
        return values.astype(np.float64)
    top = float(np.iinfo(values.dtype).max)
    scaled = values.astype(np.float64) / top
    return np.maximum(scaled, -1.0) if values.dtype.kind == "i" else scaled


# -- nodes -----------------------------------------------------------------------------------------------
def _node_parents(document: _Document, source: str) -> dict[int, int]:
    """The parent of every child node; `RigError` unless the hierarchy is a forest (glTF 2.0 sec. 3.5.3)."""
    import networkx

    nodes = document.items("nodes")
    parents: dict[int, int] = {}
    for i, node in enumerate(nodes):
        for child in document.field(node, "children", list, f"{source}: node {i}", default=[]):
            document.item("nodes", child, f"{source}: node {i} child")
            if child in parents:
                raise RigError(
                    f"{source}: node {child} is a child of both node {parents[child]} and node {i} "
                    "(glTF nodes form trees)"
                )
            parents[child] = i
    graph = networkx.DiGraph(list(parents.items()))
    try:
        cycle = networkx.find_cycle(graph)
    except networkx.NetworkXNoCycle:
        return parents
    path = " -> ".join(str(parent) for _, parent in cycle)
    raise RigError(
        f"{source}: the node hierarchy has a cycle (parents {cycle[0][0]} -> {path}); glTF nodes form trees"
    )


def _world_matrix(
    document: _Document, parents: dict[int, int], mesh_index: int, source: str
) -> tuple[np.ndarray | None, str]:
    nodes = document.items("nodes")
    for i, node in enumerate(nodes):
        if node.get("mesh") != mesh_index or not _is_int(node.get("mesh")):
            continue
        if node.get("skin") is not None:
            return None, ""
        matrix = np.eye(4)
        walk: int | None = i
        while walk is not None:
            with np.errstate(over="ignore", invalid="ignore"):  # (refused below when not finite)
                matrix = _local_matrix(nodes[walk], f"{source}: node {walk}") @ matrix
            walk = parents.get(walk)
        if not np.isfinite(matrix).all():
            raise RigError(f"{source}: node {i}: its world matrix is not finite")
        if np.allclose(matrix, np.eye(4)):
            return None, ""
        return matrix, str(node.get("name") or i)
    return None, ""


def _numbers(value: Any, size: int, label: str) -> np.ndarray:
    if (
        not isinstance(value, list)
        or len(value) != size
        or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)
    ):
        raise RigError(f"{label} must be {size} numbers, got {value!r:.60}")
    array = np.asarray(value, dtype=np.float64)
    if not np.isfinite(array).all():
        raise RigError(f"{label} holds a non-finite number")
    return array


def _local_matrix(node: dict, label: str) -> np.ndarray:
    if node.get("matrix") is not None:
        return _numbers(node["matrix"], 16, f"{label} matrix").reshape(4, 4).T
    x, y, z, w = _numbers(node.get("rotation", [0.0, 0.0, 0.0, 1.0]), 4, f"{label} rotation")
    rotation = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    scale = _numbers(node.get("scale", [1.0, 1.0, 1.0]), 3, f"{label} scale")
    matrix = np.eye(4)
    matrix[:3, :3] = rotation * scale
    matrix[:3, 3] = _numbers(node.get("translation", [0.0, 0.0, 0.0]), 3, f"{label} translation")
    return matrix


# -- welding ---------------------------------------------------------------------------------------------
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
    return neutral[keep], deltas[:, keep], welded[~_collapsed(welded)], vertex_map


# -- writing ---------------------------------------------------------------------------------------------
def glb_bytes(rig: Rig, *, mesh_name: str = "face") -> bytes:
    """A binary glTF 2.0 file of ``rig``: one mesh whose morph targets are its blendshapes.

    Positions and morph-target displacements are float32 (``POSITION`` accessors with their ``min`` and
    ``max``, as glTF 2.0 sec. 3.7.2.1 requires), triangles are uint32 indices, and the shape names are
    ``mesh.extras.targetNames``, the convention :func:`load_gltf` and most tools read. The result loads
    back with :func:`load_gltf` to the same names and, up to float32 rounding, the same deltas.

    Raises
    ------
    RigError
        When pygltflib (the ``gltf`` extra) is not installed.
    """
    try:
        import pygltflib as gl
    except ImportError:
        raise RigError(
            f"{rig.meta.get('source', 'rig')}: writing glTF needs pygltflib "
            "(pip install 'expression-packing-harness[gltf]')"
        ) from None
    arrays = [np.asarray(rig.neutral, dtype=np.float32)]
    arrays += [np.asarray(delta, dtype=np.float32) for delta in rig.deltas]
    indices = np.asarray(rig.triangles, dtype=np.uint32).ravel()
    blob = bytearray()
    views, accessors = [], []
    for values in arrays:
        views.append(gl.BufferView(buffer=0, byteOffset=len(blob), byteLength=values.nbytes, target=34962))
        accessors.append(
            gl.Accessor(
                bufferView=len(views) - 1,
                componentType=gl.FLOAT,
                count=len(values),
                type=gl.VEC3,
                min=values.min(axis=0).tolist() if len(values) else None,
                max=values.max(axis=0).tolist() if len(values) else None,
            )
        )
        blob += values.tobytes()
    views.append(gl.BufferView(buffer=0, byteOffset=len(blob), byteLength=indices.nbytes, target=34963))
    accessors.append(
        gl.Accessor(
            bufferView=len(views) - 1, componentType=gl.UNSIGNED_INT, count=len(indices), type=gl.SCALAR
        )
    )
    blob += indices.tobytes()
    primitive = gl.Primitive(
        attributes=gl.Attributes(POSITION=0),
        indices=len(accessors) - 1,
        targets=[{"POSITION": k + 1} for k in range(rig.n_shapes)],
        mode=gl.TRIANGLES,
    )
    document = gl.GLTF2(
        asset=gl.Asset(version="2.0", generator="expression-packing-harness"),
        scene=0,
        scenes=[gl.Scene(nodes=[0])],
        nodes=[gl.Node(mesh=0, name=mesh_name)],
        meshes=[
            gl.Mesh(
                name=mesh_name,
                primitives=[primitive],
                weights=[0.0] * rig.n_shapes,
                extras={"targetNames": list(rig.names)},
            )
        ],
        accessors=accessors,
        bufferViews=views,
        buffers=[gl.Buffer(byteLength=len(blob))],
    )
    document.set_binary_blob(bytes(blob))
    return b"".join(document.save_to_bytes())
