"""glTF 2.0 (``.gltf`` / ``.glb``) morph targets as a rig, read with pygltflib.

One mesh becomes the rig: its primitive's ``POSITION`` is the neutral and each morph target's ``POSITION``
is a blendshape delta (glTF morph targets are already displacements). Exporters write one primitive per
material (skin, teeth, eyelashes), all with the same morph targets; such primitives are read as one mesh.
Target names come from ``primitive.extras.targetNames`` when present, else ``mesh.extras.targetNames``
(the de-facto convention of Blender and most exporters), else ``target_<i>``.
"""

from __future__ import annotations

import base64
from pathlib import Path
from urllib.parse import unquote

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from rigs._rig import Rig, RigError

_COMPONENT_TYPES = {
    5120: np.dtype("<i1"),
    5121: np.dtype("<u1"),
    5122: np.dtype("<i2"),
    5123: np.dtype("<u2"),
    5125: np.dtype("<u4"),
    5126: np.dtype("<f4"),
}
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
    "EXT_meshopt_compression": "meshoptimizer; decode it first (e.g. `gltfpack -noq` or"
    " `gltf-transform decompress`)",
}


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
        A ``.gltf`` (buffers external or as data URIs) or ``.glb`` file.
    mesh : str or int, optional
        Name or index of the mesh; default: the primitive with the most morph targets in the file
        (ties: more vertices, then file order).
    primitive : int, optional
        Index of the one primitive to read within the chosen mesh; default: its primitive with the most
        targets, together with every other primitive of the mesh with as many targets and the same
        target names (one primitive per material, as exporters write them), vertices in primitive order.
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
    (the primitive indices read), and, after welding,
    ``meta["weld"] = {"merged": count, "vertex_map": (V,) rig vertex of each glTF vertex}``.

    Raises
    ------
    RigError
        One line naming the file and the problem: missing file, not glTF 2.0, no morph targets, unknown
        mesh, a compressed primitive (naming the extension and how to decode it), a missing buffer,
        an accessor of the wrong type or past the end of its buffer, duplicate target names.
    """
    path = Path(path)
    gltf = _open(path)
    source = str(path)
    required = set(gltf.extensionsRequired or [])
    for extension, remedy in _COMPRESSIONS.items():
        if extension in required:
            raise RigError(f"{source}: compressed with {extension} ({remedy})")
    mesh_index, primitive_index = _choose(gltf, mesh, primitive, source)
    chosen_mesh = gltf.meshes[mesh_index]
    chosen = chosen_mesh.primitives[primitive_index]
    names = _target_names(
        chosen_mesh,
        chosen,
        len(chosen.targets or []),
        _label(source, chosen_mesh, mesh_index, primitive_index),
    )
    members = (
        [primitive_index] if primitive is not None else _same_targets(chosen_mesh, primitive_index, names)
    )
    buffers = _Buffers(gltf, path)
    parts = [
        _read_primitive(gltf, buffers, chosen_mesh, j, _label(source, chosen_mesh, mesh_index, j))
        for j in members
    ]
    offsets = np.cumsum([0, *(len(part_neutral) for part_neutral, _, _ in parts[:-1])])
    neutral = np.concatenate([part[0] for part in parts])
    deltas = np.concatenate([part[1] for part in parts], axis=1)
    triangles = np.concatenate([part[2] + offset for part, offset in zip(parts, offsets, strict=True)])

    meta: dict = {
        "source": source,
        "format": "gltf",
        "units": "m",
        "mesh": chosen_mesh.name or str(mesh_index),
        "primitives": members,
    }
    if transform:
        matrix, node_name = _world_matrix(gltf, mesh_index)
        if matrix is not None:
            neutral = neutral @ matrix[:3, :3].T + matrix[:3, 3]
            deltas = deltas @ matrix[:3, :3].T
            meta["transform"] = f"world matrix of node {node_name!r}"
    if weld:
        neutral, deltas, triangles, vertex_map = weld_seams(neutral, deltas, triangles, weld_tolerance)
        meta["weld"] = {"merged": int(len(vertex_map) - len(neutral)), "vertex_map": vertex_map}
    return Rig(neutral=neutral, deltas=deltas, triangles=triangles, names=names, meta=meta)


def _label(source: str, mesh, mesh_index: int, primitive_index: int) -> str:
    return f"{source}: mesh {mesh.name or mesh_index!r} primitive {primitive_index}"


def _same_targets(mesh, chosen: int, names: tuple[str, ...]) -> list[int]:
    """The primitives of ``mesh`` with the chosen one's morph targets (count and names), in file order."""
    count = len(mesh.primitives[chosen].targets or [])
    members = []
    for j, other in enumerate(mesh.primitives):
        if j == chosen:
            members.append(j)
            continue
        if len(other.targets or []) != count or (other.mode is not None and int(other.mode) not in (4, 5, 6)):
            continue
        try:
            same = _target_names(mesh, other, count, "") == names
        except RigError:
            same = False
        if same:
            members.append(j)
    return members


def _read_primitive(gltf, buffers: _Buffers, mesh, index: int, label: str) -> tuple[np.ndarray, ...]:
    """Neutral positions, target deltas and triangles of one primitive."""
    chosen = mesh.primitives[index]
    position = _attribute(chosen.attributes, "POSITION")
    if position is None:
        raise RigError(f"{label}: has no POSITION attribute")
    draco = "KHR_draco_mesh_compression"
    if (
        draco in (chosen.extensions or {})
        and _accessor_count(gltf, position)
        and gltf.accessors[position].bufferView is None
    ):
        raise RigError(f"{label}: compressed with {draco} ({_COMPRESSIONS[draco]})")
    neutral = buffers.accessor(position, "VEC3", f"{label} POSITION")
    deltas = np.zeros((len(chosen.targets or []), len(neutral), 3))
    for k, target in enumerate(chosen.targets or []):
        target_position = _attribute(target, "POSITION")
        if target_position is not None:
            delta = buffers.accessor(target_position, "VEC3", f"{label} target {k} POSITION")
            if delta.shape != neutral.shape:
                raise RigError(f"{label}: target {k} has {len(delta)} positions for {len(neutral)} vertices")
            deltas[k] = delta
    return neutral, deltas, _triangles(buffers, chosen, len(neutral), label)


def _open(path: Path):
    from pygltflib import GLTF2

    if not path.is_file():
        raise RigError(f"{path}: no such glTF file")
    try:
        gltf = GLTF2().load(str(path))
    except Exception as error:  # pygltflib raises whatever its JSON or struct parsing meets
        raise RigError(f"{path}: not a readable glTF 2.0 file ({type(error).__name__}: {error})") from None
    if gltf is None or gltf.asset is None or not str(gltf.asset.version or "").startswith("2"):
        version = getattr(getattr(gltf, "asset", None), "version", None)
        raise RigError(f"{path}: not a glTF 2.0 file (asset.version {version!r})")
    return gltf


def _attribute(attributes, name: str) -> int | None:
    if attributes is None:
        return None
    if isinstance(attributes, dict):
        return attributes.get(name)
    return getattr(attributes, name, None)


def _choose(gltf, mesh: str | int | None, primitive: int | None, source: str) -> tuple[int, int]:
    meshes = list(gltf.meshes or [])
    if not meshes:
        raise RigError(f"{source}: has no meshes")
    if mesh is None:
        candidates = range(len(meshes))
    elif isinstance(mesh, int) and not isinstance(mesh, bool):
        if not 0 <= mesh < len(meshes):
            raise RigError(f"{source}: no mesh {mesh} (the file has {len(meshes)})")
        candidates = [mesh]
    else:
        candidates = [i for i, m in enumerate(meshes) if m.name == mesh]
        if not candidates:
            available = ", ".join(repr(m.name) for m in meshes[:8])
            raise RigError(f"{source}: no mesh named {mesh!r} (meshes: {available})")
    options = []
    for i in candidates:
        primitives = meshes[i].primitives or []
        if primitive is not None:
            if not 0 <= primitive < len(primitives):
                if mesh is None:
                    continue
                raise RigError(f"{source}: mesh {meshes[i].name or i!r} has no primitive {primitive}")
            indices = [primitive]
        else:
            indices = range(len(primitives))
        for j in indices:
            p = primitives[j]
            count = _accessor_count(gltf, _attribute(p.attributes, "POSITION"))
            options.append((len(p.targets or []), count, -i, -j))
    if not options:
        raise RigError(f"{source}: the chosen mesh has no primitives")
    best = max(options)
    if best[0] == 0:
        raise RigError(f"{source}: no mesh primitive has morph targets")
    return -best[2], -best[3]


def _accessor_count(gltf, index: int | None) -> int:
    if index is None or not 0 <= index < len(gltf.accessors or []):
        return 0
    return int(gltf.accessors[index].count or 0)


class _Buffers:
    """Decodes accessors (strided views, sparse substitution, normalised integers) of one glTF file."""

    def __init__(self, gltf, path: Path) -> None:
        self.gltf = gltf
        self.path = path
        self._data: dict[int, bytes] = {}

    def buffer(self, index: int) -> bytes:
        if index not in self._data:
            self._data[index] = self._load(index)
        return self._data[index]

    def _load(self, index: int) -> bytes:
        buffers = self.gltf.buffers or []
        if not 0 <= index < len(buffers):
            raise RigError(f"{self.path}: buffer {index} does not exist")
        uri = buffers[index].uri
        if uri is None:
            blob = self.gltf.binary_blob()
            if blob is None:
                raise RigError(f"{self.path}: buffer {index} has no URI and the file has no GLB binary chunk")
            return bytes(blob)
        if uri.startswith("data:"):
            try:
                return base64.b64decode(uri.split(",", 1)[1])
            except (IndexError, ValueError):
                raise RigError(f"{self.path}: buffer {index} has a malformed data URI") from None
        location = self.path.parent / unquote(uri)
        try:
            return location.read_bytes()
        except OSError:
            raise RigError(f"{self.path}: buffer {index} file {location} is missing") from None

    def accessor(self, index: int, kind: str, label: str) -> np.ndarray:
        accessors = self.gltf.accessors or []
        if not 0 <= index < len(accessors):
            raise RigError(f"{label}: accessor {index} does not exist")
        accessor = accessors[index]
        if accessor.type != kind or accessor.componentType not in _COMPONENT_TYPES:
            raise RigError(
                f"{label}: accessor {index} is {accessor.type} of component type {accessor.componentType}, "
                f"expected {kind}"
            )
        dtype, width, count = _COMPONENT_TYPES[accessor.componentType], _WIDTHS[kind], int(accessor.count)
        if accessor.bufferView is None:
            values = np.zeros((count, width), dtype=dtype)
        else:
            values = self._view(accessor.bufferView, accessor.byteOffset or 0, count, width, dtype, label)
        sparse = accessor.sparse
        if sparse is not None and sparse.count:
            index_type = _COMPONENT_TYPES.get(sparse.indices.componentType)
            if index_type is None or index_type.kind != "u":
                raise RigError(f"{label}: sparse indices have component type {sparse.indices.componentType}")
            where = self._view(
                sparse.indices.bufferView, sparse.indices.byteOffset or 0, sparse.count, 1, index_type, label
            ).ravel()
            if where.size and where.max() >= count:
                raise RigError(
                    f"{label}: sparse index {int(where.max())} is past the accessor's {count} elements"
                )
            replacement = self._view(
                sparse.values.bufferView, sparse.values.byteOffset or 0, sparse.count, width, dtype, label
            )
            values = values.copy()
            values[where] = replacement
        return _dequantise(values, bool(accessor.normalized)) if kind != "SCALAR" else values.ravel()

    def _view(
        self, view_index: int, offset: int, count: int, width: int, dtype: np.dtype, label: str
    ) -> np.ndarray:
        views = self.gltf.bufferViews or []
        if not 0 <= view_index < len(views):
            raise RigError(f"{label}: bufferView {view_index} does not exist")
        view = views[view_index]
        if "EXT_meshopt_compression" in (view.extensions or {}) and not self._holds_plain_data(view):
            meshopt = "EXT_meshopt_compression"
            raise RigError(f"{self.path}: compressed with {meshopt} ({_COMPRESSIONS[meshopt]})")
        data = self.buffer(view.buffer)
        element = width * dtype.itemsize
        stride = view.byteStride or element
        start = (view.byteOffset or 0) + offset
        end = start + (count - 1) * stride + element if count else start
        if end > (view.byteOffset or 0) + view.byteLength or end > len(data):
            raise RigError(
                f"{label}: reads past the end of bufferView {view_index} ({end} > {len(data)} bytes)"
            )
        if count == 0:
            return np.zeros((0, width), dtype=dtype)
        return np.ndarray(
            (count, width), dtype=dtype, buffer=data, offset=start, strides=(stride, dtype.itemsize)
        ).copy()

    def _holds_plain_data(self, view) -> bool:
        """False when a meshopt-compressed view points at a placeholder ("fallback") buffer without data."""
        buffer = (self.gltf.buffers or [])[view.buffer]
        return not (buffer.extensions or {}).get("EXT_meshopt_compression", {}).get("fallback", False)


def _dequantise(values: np.ndarray, normalized: bool) -> np.ndarray:
    """Integer accessor values as floats; normalised ones mapped to [-1, 1] or [0, 1] (glTF 2.0 sec. 3.11)."""
    if values.dtype.kind == "f" or not normalized:
        return values.astype(np.float64)
    top = float(np.iinfo(values.dtype).max)
    scaled = values.astype(np.float64) / top
    return np.maximum(scaled, -1.0) if values.dtype.kind == "i" else scaled


def _triangles(buffers: _Buffers, primitive, n_vertices: int, label: str) -> np.ndarray:
    mode = 4 if primitive.mode is None else int(primitive.mode)
    if mode not in (4, 5, 6):
        raise RigError(f"{label}: mode {mode} ({_MODES.get(mode, 'unknown')}) has no triangles")
    if primitive.indices is None:
        corners = np.arange(n_vertices, dtype=np.int64)
    else:
        corners = buffers.accessor(primitive.indices, "SCALAR", f"{label} indices").astype(np.int64)
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


def _target_names(mesh, primitive, count: int, label: str) -> tuple[str, ...]:
    names = None
    for holder in (primitive, mesh):
        extras = holder.extras if isinstance(holder.extras, dict) else {}
        if extras.get("targetNames") is not None:
            names = extras["targetNames"]
            break
    if names is None:
        return tuple(f"target_{k}" for k in range(count))
    if not isinstance(names, list) or len(names) != count:
        size = len(names) if isinstance(names, list) else names
        raise RigError(f"{label}: extras.targetNames has {size} names for {count} morph targets")
    seen: set[str] = set()
    for name in names:
        if str(name) in seen:
            raise RigError(f"{label}: duplicate morph target name {str(name)!r} in extras.targetNames")
        seen.add(str(name))
    return tuple(str(name) for name in names)


def _world_matrix(gltf, mesh_index: int) -> tuple[np.ndarray | None, str]:
    nodes = list(gltf.nodes or [])
    parents = {child: i for i, node in enumerate(nodes) for child in (node.children or [])}
    for i, node in enumerate(nodes):
        if node.mesh != mesh_index:
            continue
        if node.skin is not None:
            return None, ""
        matrix = np.eye(4)
        walk: int | None = i
        while walk is not None:
            matrix = _local_matrix(nodes[walk]) @ matrix
            walk = parents.get(walk)
        if np.allclose(matrix, np.eye(4)):
            return None, ""
        return matrix, nodes[i].name or str(i)
    return None, ""


def _local_matrix(node) -> np.ndarray:
    if node.matrix is not None and len(node.matrix) == 16:
        return np.asarray(node.matrix, dtype=np.float64).reshape(4, 4).T
    x, y, z, w = node.rotation if node.rotation is not None else (0.0, 0.0, 0.0, 1.0)
    rotation = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    scale = np.asarray(node.scale if node.scale is not None else (1.0, 1.0, 1.0), dtype=np.float64)
    matrix = np.eye(4)
    matrix[:3, :3] = rotation * scale
    matrix[:3, 3] = node.translation if node.translation is not None else (0.0, 0.0, 0.0)
    return matrix


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
    intact = (welded[:, 0] != welded[:, 1]) & (welded[:, 1] != welded[:, 2]) & (welded[:, 0] != welded[:, 2])
    return neutral[keep], deltas[:, keep], welded[intact], vertex_map
