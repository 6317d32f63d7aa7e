"""glTF buffers and accessors: buffer bytes from the GLB chunk, ``data:`` URIs or files inside the glTF's
folder, strided views, sparse substitution, normalised integers and meshopt-compressed views."""

from __future__ import annotations

import base64
import binascii
import os
from pathlib import Path
from urllib.parse import unquote, unquote_to_bytes, urlsplit

import numpy as np

from rigs._gltf_document import COMPONENT_TYPES, COMPRESSIONS, INDEX_TYPES, Document, is_int, meshopt_decoder
from rigs._rig import RigError
from rigs._safe import named_path, read_bytes

_WIDTHS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}


#: meshopt filters a decoded view may declare; the others (OCTAHEDRAL, QUATERNION, EXPONENTIAL) pack
#: normals, rotations and exponents, which are not rig data.
_MESHOPT_FILTERS = ("NONE",)


#: A meshopt view decodes to at most this many times its compressed bytes (plus `_MESHOPT_SLACK`).
_MESHOPT_RATIO = 256


_MESHOPT_SLACK = 2**20


class Buffers:
    """Decodes accessors (strided views, sparse substitution, normalised integers) of one glTF file.

    ``source_bytes`` counts the bytes of the glTF file and of the buffer files read so far, the measure
    against which decoded arrays are budgeted.
    """

    def __init__(self, document: Document, path: Path, blob: memoryview | None, size: int) -> None:
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
            data = _data_uri(uri, label, length)
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
                    if compressed is not None and meshopt_decoder() is not None:
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
        components: dict[int, np.dtype] = COMPONENT_TYPES,
    ) -> np.ndarray:
        """The values of accessor ``index``, checked to be ``kind`` of ``components`` and, when ``count``
        is given, to have that many elements (before anything is allocated)."""
        document = self.document
        accessor = document.item("accessors", index, label)
        where = f"{label}: accessor {index}"
        component = accessor.get("componentType")
        if accessor.get("type") != kind or not is_int(component) or component not in components:
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
        return dequantise(values, normalized) if kind != "SCALAR" else values.ravel()

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
        if not is_int(index_type) or index_type not in INDEX_TYPES:
            raise RigError(f"{label} indices have component type {index_type!r:.20}")
        where_view = document.count(indices, "bufferView", f"{label} indices")
        positions = (
            self._view(
                where_view,
                document.count(indices, "byteOffset", f"{label} indices", default=0),
                count,
                1,
                INDEX_TYPES[index_type],
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
        if compressed is not None and meshopt_decoder() is not None:
            data = self._decode_meshopt(compressed, where)
            view = {"byteLength": len(data), "byteStride": compressed["byteStride"]}
        elif compressed is not None and not self._holds_plain_data(view):
            meshopt = "EXT_meshopt_compression"
            raise RigError(f"{self.path}: compressed with {meshopt} ({COMPRESSIONS[meshopt]})")
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
        decoder = meshopt_decoder()
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


#: Bytes a buffer may hold beyond its ``byteLength`` (the padding to four bytes glTF allows).
PADDING = 3


def _data_uri(uri: str, label: str, length: int) -> bytes:
    """The bytes of a ``data:`` URI (RFC 2397): base64 when its header ends in ``;base64``, else
    percent-encoded; more than the buffer's ``length`` (and its padding) is refused, before decoding
    when the encoded size already says so (each base64 character holds 3/4 of a byte, a percent
    escape a third)."""
    header, comma, payload = uri[len("data:") :].partition(",")
    if not comma:
        raise RigError(f"{label}: malformed data URI (no ',' before the data)")
    base64_encoded = header.endswith(";base64")
    least = len(payload) * 3 // 4 - 2 if base64_encoded else len(payload) // 3
    if least > length + PADDING:
        raise RigError(f"{label}: its data URI holds about {least} bytes, more than its byteLength {length}")
    try:
        data = base64.b64decode(payload, validate=True) if base64_encoded else unquote_to_bytes(payload)
    except (binascii.Error, ValueError) as error:
        raise RigError(f"{label}: malformed base64 in its data URI ({error})") from None
    if len(data) > length + PADDING:
        raise RigError(f"{label}: its data URI holds {len(data)} bytes, more than its byteLength {length}")
    return data


def dequantise(values: np.ndarray, normalized: bool) -> np.ndarray:
    """Integer accessor values as floats; normalised ones mapped to [-1, 1] or [0, 1] (glTF 2.0 sec. 3.11)."""
    if values.dtype.kind == "f" or not normalized:
        return values.astype(np.float64)
    top = float(np.iinfo(values.dtype).max)
    scaled = values.astype(np.float64) / top
    return np.maximum(scaled, -1.0) if values.dtype.kind == "i" else scaled
