"""The glTF 2.0 JSON document, read as untrusted: the GLB container chunk by chunk, the JSON with
:mod:`json`, typed and range-checked field access, the required extensions and the node hierarchy.

Every field the reader uses is checked for its type and range by `Document` (pygltflib's decoder coerces
mistyped fields, turning a ``bufferView`` of 1.5 into 1, so it is not used for reading; no JSON-schema
library is a dependency, and the checks that matter, indices in range and sizes against the bytes, are
beyond a schema). The node hierarchy must be a forest (no cycles, one parent per node).
"""

from __future__ import annotations

import json
import struct
from pathlib import Path
from typing import Any

import numpy as np

from rigs._rig import RigError
from rigs._safe import read_bytes

COMPONENT_TYPES = {
    5120: np.dtype("<i1"),
    5121: np.dtype("<u1"),
    5122: np.dtype("<i2"),
    5123: np.dtype("<u2"),
    5125: np.dtype("<u4"),
    5126: np.dtype("<f4"),
}


#: Component types an index accessor may have (glTF 2.0 sec. 3.7.2.1: unsigned integers only).
INDEX_TYPES = {key: COMPONENT_TYPES[key] for key in (5121, 5123, 5125)}


COMPRESSIONS = {
    "KHR_draco_mesh_compression": "Draco; decode it first (e.g. `gltf-transform decompress in.glb out.glb`)"
    " or install DracoPy and convert",
    "EXT_meshopt_compression": "meshoptimizer; install a decoder (pip install almeshopt) or write it "
    "uncompressed first: `gltfpack -i in.glb -o out.glb -noq`",
}


#: Required extensions this reader implements (quantised positions are dequantised, see `dequantise`).
_IMPLEMENTED = {"KHR_mesh_quantization", "EXT_meshopt_compression"}


#: Required extensions that change only how the mesh looks, never its positions: safe to ignore.
_APPEARANCE_PREFIXES = ("KHR_materials_", "KHR_texture_", "EXT_texture_", "KHR_lights_", "EXT_lights_")


_GLB_MAGIC = b"glTF"


_JSON_CHUNK, _BIN_CHUNK = b"JSON", b"BIN\x00"


class Document:
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
        if not is_int(index) or not 0 <= index < len(values):
            raise RigError(f"{label}: {singular} {index!r:.40} does not exist (the file has {len(values)})")
        return values[index]

    def field(self, obj: dict, key: str, kind: type, label: str, default: Any = None) -> Any:
        """``obj[key]`` checked to be a ``kind`` (``default`` when absent)."""
        value = obj.get(key, default)
        if value is default:
            return value
        if kind is int:
            valid = is_int(value)
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
        if not is_int(value) or value < minimum:
            raise RigError(f"{label}: '{key}' must be an integer >= {minimum}, got {value!r:.40}")
        return value


_KIND_NAMES = {int: "an integer", str: "a string", list: "an array", dict: "an object", bool: "true or false"}


def is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def numbers(value: Any, size: int, label: str) -> np.ndarray:
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


def open_gltf(path: Path) -> tuple[Document, memoryview | None, int]:
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
    return Document(content, str(path)), blob, len(data)


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


def check_extensions(document: Document, source: str) -> None:
    required = document.content.get("extensionsRequired", [])
    if not isinstance(required, list) or not all(isinstance(name, str) for name in required):
        raise RigError(f"{source}: 'extensionsRequired' must be an array of extension names")
    for extension, remedy in COMPRESSIONS.items():
        decodable = extension == "EXT_meshopt_compression" and meshopt_decoder() is not None
        if extension in required and not decodable:
            raise RigError(f"{source}: compressed with {extension} ({remedy})")
    for extension in required:
        if extension not in _IMPLEMENTED and not extension.startswith(_APPEARANCE_PREFIXES):
            raise RigError(
                f"{source}: requires extension {extension!r:.80}, which this reader does not implement "
                "(it reads KHR_mesh_quantization and ignores material, texture and light extensions)"
            )


def meshopt_decoder() -> Any | None:
    """The meshoptimizer decoder (the ``almeshopt`` package), or None when it is not installed."""
    try:
        import almeshopt
    except ImportError:
        return None
    return almeshopt


def node_parents(document: Document, source: str) -> dict[int, int]:
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


def world_matrix(
    document: Document, parents: dict[int, int], mesh_index: int, source: str
) -> tuple[np.ndarray | None, str]:
    nodes = document.items("nodes")
    for i, node in enumerate(nodes):
        if node.get("mesh") != mesh_index or not is_int(node.get("mesh")):
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


#: How far a node's rotation may be from a unit quaternion (glTF 2.0 requires one; exporters round): beyond
#: it, a zero or a scaled quaternion is refused rather than taken for a rotation it is not.
UNIT_QUATERNION_TOLERANCE = 1e-3


def _local_matrix(node: dict, label: str) -> np.ndarray:
    if node.get("matrix") is not None:
        return numbers(node["matrix"], 16, f"{label} matrix").reshape(4, 4).T
    x, y, z, w = numbers(node.get("rotation", [0.0, 0.0, 0.0, 1.0]), 4, f"{label} rotation")
    length = float(np.sqrt(x * x + y * y + z * z + w * w))
    if not abs(length - 1.0) <= UNIT_QUATERNION_TOLERANCE:
        raise RigError(
            f"{label} rotation {[float(v) for v in (x, y, z, w)]} is not a unit quaternion (its length is "
            f"{length:.6g})"
        )
    rotation = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    scale = numbers(node.get("scale", [1.0, 1.0, 1.0]), 3, f"{label} scale")
    matrix = np.eye(4)
    matrix[:3, :3] = rotation * scale
    matrix[:3, 3] = numbers(node.get("translation", [0.0, 0.0, 0.0]), 3, f"{label} translation")
    return matrix
