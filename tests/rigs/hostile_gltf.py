"""Hostile-input corpus (`tests/rigs/test_hostile_inputs.py`): glTF JSON files."""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from pathlib import Path

import numpy as np

from tests.rigs.hostile_corpus import add, case

GLTF_NEUTRAL = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0], [2, 1, 0]], dtype=np.float32)
GLTF_DELTAS = np.zeros((2, 6, 3), dtype=np.float32)
GLTF_DELTAS[0, 2] = [0, 0.25, 0.5]
GLTF_DELTAS[1, 4] = [0, 0, -0.125]
GLTF_INDICES = np.array([0, 1, 2, 0, 2, 3, 1, 4, 5, 1, 5, 2], dtype=np.uint32)


def gltf_document() -> tuple[dict, bytes]:
    """A valid glTF: one mesh, one primitive, two morph targets; accessors 0 POSITION, 1-2 targets,
    3 indices; buffer views alike."""
    parts = [GLTF_NEUTRAL, GLTF_DELTAS[0], GLTF_DELTAS[1], GLTF_INDICES]
    blob, views = b"", []
    for array in parts:
        data = array.tobytes()
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data)})
        blob += data
    accessors = [{"bufferView": k, "componentType": 5126, "count": 6, "type": "VEC3"} for k in range(3)] + [
        {"bufferView": 3, "componentType": 5125, "count": 12, "type": "SCALAR"}
    ]
    document = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": "Head"}],
        "meshes": [
            {
                "name": "Face",
                "primitives": [
                    {
                        "attributes": {"POSITION": 0},
                        "indices": 3,
                        "targets": [{"POSITION": 1}, {"POSITION": 2}],
                    }
                ],
                "extras": {"targetNames": ["jawOpen", "smile"]},
            }
        ],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(blob), "uri": "mesh.bin"}],
    }
    return document, blob


def write_gltf(folder: Path, document: dict, blob: bytes, *, text: str | None = None) -> Path:
    path = folder / "face.gltf"
    (folder / "mesh.bin").write_bytes(blob)
    path.write_text(text if text is not None else json.dumps(document))
    return path


def gltf_case(name: str, mutate: Callable[[dict, Path], object], error: str | None = None, **kwargs) -> None:
    """A case from the valid document changed in place by ``mutate(document, folder)``."""

    def build(folder: Path) -> tuple[Path, dict]:
        document, blob = gltf_document()
        mutate(document, folder)
        return write_gltf(folder, document, blob), {}

    add(f"gltf/{name}", build, error, **kwargs)


def setter(path: str, value: object) -> Callable[[dict, Path], None]:
    """Set ``document[a][b]...`` for the dotted ``path`` (list indices as numbers); ``...`` deletes."""

    def mutate(document: dict, folder: Path) -> None:
        keys = [int(k) if k.isdigit() else k for k in path.split(".")]
        holder = document
        for key in keys[:-1]:
            holder = holder[key]
        if value is ...:
            del holder[keys[-1]]
        else:
            holder[keys[-1]] = value

    return mutate


def uri(value: str) -> Callable[[dict, Path], None]:
    def mutate(document: dict, folder: Path) -> None:
        (folder.parent / "secret.bin").write_bytes(gltf_document()[1])  # a real buffer, outside the folder
        document["buffers"][0]["uri"] = value

    return mutate


def uri_entry(kind: str) -> Callable[[dict, Path], None]:
    def mutate(document: dict, folder: Path) -> None:
        entry = folder / "link.bin"
        secret = folder.parent / "secret.bin"
        secret.write_bytes(gltf_document()[1])
        if kind == "fifo":
            os.mkfifo(entry)
        elif kind == "outside":
            entry.symlink_to(secret)
        elif kind == "dangling":
            entry.symlink_to(folder / "gone.bin")
        elif kind == "loop":
            entry.symlink_to(entry)
        elif kind == "dev-zero":
            entry.symlink_to("/dev/zero")
        elif kind == "folder":
            entry.mkdir()
        document["buffers"][0]["uri"] = "link.bin"

    return mutate


def sparse(
    count: int, *, view: int = 3, component: int = 5125, offset: int | None = None, values: bool = True
) -> Callable[[dict, Path], None]:
    """Give accessor 1 (the first morph target) ``count`` sparse substitutions: indices of component type
    ``component`` read from bufferView ``view`` (at byte ``offset``), values from bufferView 1 (or none)."""
    indices = {"bufferView": view, "componentType": component}
    if offset is not None:
        indices["byteOffset"] = offset
    substitutions = {"count": count, "indices": indices}
    if values:
        substitutions["values"] = {"bufferView": 1}
    return setter("accessors.1.sparse", substitutions)


PRIMITIVE = "meshes.0.primitives.0"
#: Cases that would allocate gigabytes (or read /dev/zero) if the reader trusted the file.
HEAVY = {
    "target-count-1e9-no-view",
    "neutral-count-1e9",
    "uri-dev-zero",
    "uri-link-dev-zero",
    "header-claims-218-TiB",
}
for label, mutate, error in [
    ("uri-dotdot", uri("../secret.bin"), r"face\.gltf: buffer 0 URI: '\.\./secret\.bin' leaves the folder"),
    ("uri-percent-dotdot", uri("%2e%2e/secret.bin"), r"buffer 0 URI: '\.\./secret\.bin' leaves the folder"),
    ("uri-percent-slash", uri("%2E%2E%2Fsecret.bin"), r"buffer 0 URI: '\.\./secret\.bin' leaves the folder"),
    ("uri-inner-dotdot", uri("sub/../../secret.bin"), r"buffer 0 URI: 'sub/\.\./\.\./secret\.bin' leaves"),
    ("uri-absolute", uri("/etc/hostname"), r"buffer 0 URI: '/etc/hostname' is an absolute path"),
    ("uri-percent-absolute", uri("%2Fetc%2Fhostname"), r"buffer 0 URI: '/etc/hostname' is an absolute path"),
    ("uri-dev-zero", uri("/dev/zero"), r"buffer 0 URI: '/dev/zero' is an absolute path"),
    ("uri-file-scheme", uri("file:///etc/hostname"), r"buffer 0: URI 'file:///etc/hostname' names a scheme"),
    (
        "uri-http",
        uri("http://127.0.0.1/mesh.bin"),
        r"buffer 0: URI 'http://127\.0\.0\.1/mesh\.bin' names a scheme",
    ),
    ("uri-drive-letter", uri("C:/mesh.bin"), r"buffer 0: URI 'C:/mesh\.bin' names a scheme"),
    ("uri-unc", uri("\\\\server\\share\\mesh.bin"), r"is an absolute path"),
    ("uri-nul", uri("mesh.bin%00.png"), r"buffer 0 URI: file name .* holds a NUL byte"),
    ("uri-ipv6-garbage", uri("http://[::1/mesh.bin"), r"buffer 0: URI .* is malformed"),
    ("uri-missing", uri("nothere.bin"), r"buffer 0 file .*nothere\.bin is missing"),
    ("uri-not-string", setter("buffers.0.uri", 5), r"buffer 0: 'uri' must be a string, got 5"),
    ("uri-fifo", uri_entry("fifo"), r"buffer 0: .*link\.bin: is a FIFO"),
    ("uri-link-outside", uri_entry("outside"), r"buffer 0: .*link\.bin: resolves to .*secret\.bin, outside"),
    ("uri-link-dangling", uri_entry("dangling"), r"buffer 0: .*link\.bin: symbolic link to .*gone\.bin"),
    ("uri-link-loop", uri_entry("loop"), r"buffer 0: .*link\.bin: symbolic link loop"),
    ("uri-link-dev-zero", uri_entry("dev-zero"), r"buffer 0: .*link\.bin: is a character device"),
    ("uri-folder", uri_entry("folder"), r"buffer 0: .*link\.bin: is a folder"),
    (
        "data-uri-no-comma",
        setter("buffers.0.uri", "data:application/octet-stream;base64"),
        r"malformed data URI",
    ),
    (
        "data-uri-bad-alphabet",
        setter("buffers.0.uri", "data:;base64,!!!!"),
        r"malformed base64 in its data URI",
    ),
    ("data-uri-bad-padding", setter("buffers.0.uri", "data:;base64,QUJD" + "A"), r"malformed base64"),
    ("data-uri-non-ascii", setter("buffers.0.uri", "data:;base64,QUJDé"), r"malformed base64"),
    (
        "data-uri-short",
        setter("buffers.0.uri", "data:;base64,QUJD"),
        r"buffer 0 holds 3 bytes, fewer than its byteLength",
    ),
    (
        "data-uri-percent-short",
        setter("buffers.0.uri", "data:,%00%01"),
        r"buffer 0 holds 2 bytes, fewer than",
    ),
    (
        "byte-length-zero",
        setter("buffers.0.byteLength", 0),
        r"buffer 0: 'byteLength' must be an integer >= 1",
    ),
    ("byte-length-negative", setter("buffers.0.byteLength", -5), r"'byteLength' must be an integer >= 1"),
    (
        "byte-length-string",
        setter("buffers.0.byteLength", "264"),
        r"'byteLength' must be an integer >= 1, got '264'",
    ),
    (
        "byte-length-huge",
        setter("buffers.0.byteLength", 10**15),
        r"buffer 0 holds 264 bytes, fewer than its byteLength",
    ),
    ("byte-length-missing", setter("buffers.0.byteLength", ...), r"buffer 0: 'byteLength' is missing"),
    ("buffers-missing", setter("buffers", ...), r"buffer 0 does not exist \(the file has 0\)"),
    (
        "no-uri-no-glb",
        setter("buffers.0.uri", ...),
        r"buffer 0 has no URI and the file has no GLB binary chunk",
    ),
    (
        "target-count-1e9-no-view",
        lambda d, f: d["accessors"][1].update(count=10**9, bufferView=None),
        r"target 0 has 1000000000 positions for 6 vertices",
    ),
    (
        "target-count-short",
        setter("accessors.1.count", 5),
        r"primitive 0: target 0 has 5 positions for 6 vertices",
    ),
    (
        "neutral-count-1e9",
        setter("accessors.0.count", 10**9),
        r"face\.gltf: .*1000000000 vertices would take|reads past the end",
    ),
    (
        "neutral-no-view",
        setter("accessors.0.bufferView", ...),
        r"POSITION: accessor 0 has no bufferView; the neutral positions must be stored",
    ),
    (
        "neutral-sparse-only",
        lambda d, f: d["accessors"][0].update(bufferView=None, sparse={"count": 1}),
        r"accessor 0 has no bufferView",
    ),
    (
        "count-negative",
        setter("accessors.1.count", -1),
        r"target 0 POSITION: accessor 1: 'count' must be an integer >= 0",
    ),
    ("count-float", setter("accessors.1.count", 6.0), r"'count' must be an integer >= 0, got 6\.0"),
    ("count-bool", setter("accessors.1.count", True), r"'count' must be an integer >= 0, got True"),
    ("count-missing", setter("accessors.0.count", ...), r"accessor 0: 'count' is missing"),
    (
        "component-double",
        setter("accessors.0.componentType", 5130),
        r"accessor 0 is 'VEC3' of component type 5130, expected VEC3",
    ),
    (
        "component-string",
        setter("accessors.1.componentType", "5126"),
        r"accessor 1 is 'VEC3' of component type '5126'",
    ),
    (
        "type-vec2",
        setter("accessors.0.type", "VEC2"),
        r"accessor 0 is 'VEC2' of component type 5126, expected VEC3",
    ),
    ("type-missing", setter("accessors.2.type", ...), r"accessor 2 is None of component type"),
    (
        "stride-small",
        setter("bufferViews.0.byteStride", 4),
        r"bufferView 0: byteStride 4 is smaller than the 12-byte elements",
    ),
    ("stride-zero", setter("bufferViews.1.byteStride", 0), r"byteStride 0 is smaller than the 12-byte"),
    ("stride-negative", setter("bufferViews.1.byteStride", -12), r"'byteStride' must be an integer >= 0"),
    ("stride-huge", setter("bufferViews.1.byteStride", 2**40), r"reads past the end of bufferView 1"),
    (
        "view-offset-past-buffer",
        setter("bufferViews.2.byteOffset", 10**6),
        r"reads past the end of bufferView 2",
    ),
    (
        "accessor-offset-negative",
        setter("accessors.1.byteOffset", -4),
        r"accessor 1: 'byteOffset' must be an integer >= 0",
    ),
    (
        "accessor-offset-past-view",
        setter("accessors.1.byteOffset", 64),
        r"reads past the end of bufferView 1",
    ),
    (
        "view-out-of-range",
        setter("accessors.1.bufferView", 9),
        r"bufferView 9 does not exist \(the file has 4\)",
    ),
    ("view-negative", setter("accessors.1.bufferView", -1), r"bufferView -1 does not exist"),
    ("view-fractional", setter("accessors.1.bufferView", 1.5), r"bufferView 1\.5 does not exist"),
    (
        "view-buffer-out-of-range",
        setter("bufferViews.0.buffer", 3),
        r"buffer 3 does not exist \(the file has 1\)",
    ),
    (
        "view-length-missing",
        setter("bufferViews.0.byteLength", ...),
        r"bufferView 0: 'byteLength' is missing",
    ),
    (
        "view-length-short",
        setter("bufferViews.0.byteLength", 8),
        r"POSITION: reads past the end of bufferView 0",
    ),
    (
        "indices-float",
        setter("accessors.3.componentType", 5126),
        r"indices: accessor 3 is 'SCALAR' of component type 5126, expected SCALAR of 5121/5123/5125",
    ),
    (
        "indices-signed",
        setter("accessors.3.componentType", 5122),
        r"indices: accessor 3 is 'SCALAR' of component type 5122",
    ),
    ("indices-not-triples", setter("accessors.3.count", 11), r"11 triangle indices is not a multiple of 3"),
    (
        "indices-no-view",
        setter("accessors.3.bufferView", ...),
        r"indices: accessor 3 has no bufferView: it holds no data",
    ),
    (
        "index-past-vertices",
        lambda d, f: (
            d["accessors"].append(
                {"bufferView": 0, "componentType": 5125, "count": 3, "type": "SCALAR", "byteOffset": 4}
            )
            or d["meshes"][0]["primitives"][0].update(indices=4)
        ),
        r"index \d+ is past the 6 vertices",
    ),
    ("indices-out-of-range", setter(f"{PRIMITIVE}.indices", 12), r"accessor 12 does not exist"),
    ("sparse-count-past", sparse(99), r"sparse: 99 substitutions for 6 elements"),
    ("sparse-repeated-index", sparse(2, offset=8), r"sparse: indices do not strictly increase"),
    (
        "sparse-index-past",
        sparse(1, view=0, offset=12),
        r"sparse: index 1065353216 is past the accessor's 6 elements",
    ),
    ("sparse-index-float", sparse(1, component=5126), r"sparse indices have component type 5126"),
    ("sparse-no-values", sparse(1, values=False), r"sparse: needs 'indices' and 'values'"),
    ("sparse-not-object", setter("accessors.1.sparse", [1, 2]), r"accessor 1: 'sparse' must be an object"),
    (
        "sparse-count-negative",
        setter("accessors.1.sparse", {"count": -2}),
        r"sparse: 'count' must be an integer >= 0",
    ),
    (
        "normalized-string",
        setter("accessors.0.normalized", "yes"),
        r"accessor 0: 'normalized' must be true or false",
    ),
    ("target-index-string", setter(f"{PRIMITIVE}.targets.0.POSITION", "1"), r"accessor '1' does not exist"),
    (
        "target-other-attribute-string",
        setter(f"{PRIMITIVE}.targets.0", {"NORMAL": "x"}),
        r"target 0 has an attribute that is not an accessor index",
    ),
    ("targets-not-list", setter(f"{PRIMITIVE}.targets", {"POSITION": 1}), r"'targets' must be an array"),
    ("target-not-object", setter(f"{PRIMITIVE}.targets", [1, 2]), r"every morph target must be an object"),
    ("no-targets", setter(f"{PRIMITIVE}.targets", []), r"face\.gltf: no mesh primitive has morph targets"),
    (
        "target-names-count",
        setter("meshes.0.extras.targetNames", ["a"]),
        r"extras\.targetNames has 1 names for 2 morph targets",
    ),
    (
        "target-names-not-list",
        setter("meshes.0.extras.targetNames", "ab"),
        r"extras\.targetNames has 'ab' names",
    ),
    (
        "target-names-number",
        setter("meshes.0.extras.targetNames", ["a", 5]),
        r"extras\.targetNames holds 5, not a name",
    ),
    (
        "target-names-duplicate",
        setter("meshes.0.extras.targetNames", ["a", "a"]),
        r"duplicate morph target name 'a'",
    ),
    (
        "target-names-empty",
        setter("meshes.0.extras.targetNames", ["", "b"]),
        r"face\.gltf: a blendshape has an empty name",
    ),
    (
        "extension-unknown",
        setter("extensionsRequired", ["EXT_unheard_of"]),
        r"requires extension 'EXT_unheard_of', which this reader does not implement",
    ),
    (
        "extension-instancing",
        setter("extensionsRequired", ["EXT_mesh_gpu_instancing"]),
        r"requires extension 'EXT_mesh_gpu_instancing'",
    ),
    (
        "extension-draco",
        setter("extensionsRequired", ["KHR_draco_mesh_compression"]),
        r"compressed with KHR_draco_mesh_compression",
    ),
    (
        "extensions-not-list",
        setter("extensionsRequired", "KHR_mesh_quantization"),
        r"'extensionsRequired' must be an array of extension names",
    ),
    ("extension-number", setter("extensionsRequired", [5]), r"'extensionsRequired' must be an array"),
    ("node-own-child", setter("nodes.0.children", [0]), r"the node hierarchy has a cycle \(parents 0 -> 0\)"),
    (
        "node-two-cycle",
        lambda d, f: d.update(nodes=[{"mesh": 0, "children": [1]}, {"children": [0]}]),
        r"the node hierarchy has a cycle",
    ),
    (
        "node-cycle-elsewhere",
        lambda d, f: d["nodes"].extend([{"children": [2]}, {"children": [3]}, {"children": [1]}]),
        r"the node hierarchy has a cycle",
    ),
    (
        "node-two-parents",
        lambda d, f: d["nodes"].extend([{"children": [0]}, {"children": [0]}]),
        r"node 0 is a child of both node 1 and node 2",
    ),
    ("node-child-out-of-range", setter("nodes.0.children", [7]), r"node 0 child: node 7 does not exist"),
    ("node-children-not-list", setter("nodes.0.children", 1), r"node 0: 'children' must be an array"),
    ("node-matrix-15", setter("nodes.0.matrix", [1.0] * 15), r"node 0 matrix must be 16 numbers"),
    ("node-matrix-string", setter("nodes.0.matrix", "identity"), r"node 0 matrix must be 16 numbers"),
    (
        "node-translation-nan",
        lambda d, f: d["nodes"][0].update(translation=[float("nan"), 0, 0]),
        r"node 0 translation holds a non-finite number",
    ),
    (
        "node-scale-overflow",
        lambda d, f: d.update(
            nodes=[{"mesh": 0, "scale": [1e200] * 3}, {"children": [0], "scale": [1e200] * 3}]
        ),
        r"node 0: its world matrix is not finite",
    ),
    ("node-rotation-bool", setter("nodes.0.rotation", [True, 0, 0, 1]), r"node 0 rotation must be 4 numbers"),
    ("nodes-not-list", setter("nodes", {"0": {}}), r"'nodes' must be an array of objects"),
    ("mode-lines", setter(f"{PRIMITIVE}.mode", 1), r"primitive 0: mode 1 \(LINES\) has no triangles"),
    ("mode-string", setter(f"{PRIMITIVE}.mode", "4"), r"primitive 0: 'mode' must be an integer, got '4'"),
    ("mode-unknown", setter(f"{PRIMITIVE}.mode", 9), r"mode 9 \(unknown\) has no triangles"),
    ("asset-missing", setter("asset", ...), r"face\.gltf: not a glTF 2\.0 file \(asset\.version None\)"),
    ("asset-version-1", setter("asset.version", "1.0"), r"not a glTF 2\.0 file \(asset\.version '1\.0'\)"),
    ("asset-version-number", setter("asset.version", 2), r"not a glTF 2\.0 file \(asset\.version 2\)"),
    ("meshes-not-list", setter("meshes", {"Face": 1}), r"'meshes' must be an array of objects"),
    ("meshes-empty", setter("meshes", []), r"face\.gltf: has no meshes"),
    ("primitives-missing", setter("meshes.0.primitives", ...), r"the chosen mesh has no primitives"),
    ("primitive-not-object", setter("meshes.0.primitives", [3]), r"primitive 0: is not an object"),
    (
        "attributes-not-object",
        setter(f"{PRIMITIVE}.attributes", [0]),
        r"primitive 0: 'attributes' must be an object",
    ),
    (
        "position-missing",
        setter(f"{PRIMITIVE}.attributes", {"NORMAL": 0}),
        r"primitive 0: has no POSITION attribute",
    ),
    ("accessors-missing", setter("accessors", ...), r"accessor 0 does not exist \(the file has 0\)"),
    ("accessors-not-list", setter("accessors", 4), r"'accessors' must be an array of objects"),
    ("accessor-not-object", setter("accessors.2", 7), r"'accessors' must be an array of objects"),
]:
    gltf_case(label, mutate, error, heavy=label in HEAVY)


def gltf_bytes_case(name: str, change: Callable[[bytearray], None], error: str) -> None:
    """A case from the valid document whose buffer bytes ``change`` edits (data written after)."""

    def build(folder: Path) -> tuple[Path, dict]:
        document, blob = gltf_document()
        data = bytearray(blob)
        change(data)
        return write_gltf(folder, document, bytes(data)), {}

    add(f"gltf/{name}", build, error)


gltf_bytes_case(
    "target-inf",
    lambda data: data.__setitem__(slice(72 + 24, 72 + 28), np.float32(np.inf).tobytes()),
    r"blendshape 'jawOpen' has a non-finite displacement at vertex 2",
)
gltf_bytes_case(
    "target-nan",
    lambda data: data.__setitem__(slice(144 + 48, 144 + 52), np.float32(np.nan).tobytes()),
    r"blendshape 'smile' has a non-finite displacement at vertex 4",
)
gltf_bytes_case(
    "index-huge",
    lambda data: data.__setitem__(slice(216, 220), np.uint32(2**32 - 1).tobytes()),
    r"index 4294967295 is past the 6 vertices",
)
gltf_bytes_case(
    "neutral-nan",
    lambda data: data.__setitem__(slice(0, 4), b"\xff\xff\xff\x7f"),
    r"face\.gltf: neutral has a non-finite coordinate at vertex 0",
)
gltf_bytes_case(
    "bin-truncated",
    lambda data: data.__delitem__(slice(200, None)),
    r"buffer 0 holds 200 bytes, fewer than its byteLength 264",
)

for label, text, error in [
    ("not-json", "{ not json", r"face\.gltf: not a readable glTF 2\.0 file \(JSONDecodeError"),
    ("top-level-array", "[1, 2, 3]", r"not a readable glTF 2\.0 file \(the JSON is not an object\)"),
    (
        "deep-nesting",
        '{"a": ' + "[" * 200_000 + "]" * 200_000 + "}",
        r"not a readable glTF 2\.0 file \(RecursionError",
    ),
    (
        "huge-int",
        '{"asset": {"version": "2.0"}, "x": ' + "9" * 100_000 + "}",
        r"not a readable glTF 2\.0 file",
    ),
    ("nan-literal", '{"asset": {"version": "2.0"}, "meshes": NaN}', r"'meshes' must be an array of objects"),
    ("empty", "", r"not a readable glTF 2\.0 file"),
    ("no-meshes-key", '{"asset": {"version": "2.0"}}', r"face\.gltf: has no meshes"),
]:
    add(f"gltf/json-{label}", lambda folder, text=text: (write_gltf(folder, {}, b"", text=text), {}), error)


@case("gltf/json-invalid-utf8", r"face\.gltf: not a readable glTF 2\.0 file")
def _invalid_utf8(folder: Path) -> tuple[Path, dict]:
    path = folder / "face.gltf"
    path.write_bytes(b'{"asset": {"version": "2.0\xff\xfe"}}')
    return path, {}


def top_level_gltf(kind: str) -> Callable[[Path], tuple[Path, dict]]:
    def build(folder: Path) -> tuple[Path, dict]:
        path = folder / "face.gltf"
        if kind == "fifo":
            os.mkfifo(path)
        elif kind == "dev-zero":
            path.symlink_to("/dev/zero")
        else:
            path.symlink_to(folder / "gone.gltf")
        return path, {}

    return build


add("gltf/file-fifo", top_level_gltf("fifo"), r"face\.gltf: is a FIFO \(named pipe\), not a regular file")
add(
    "gltf/file-dev-zero", top_level_gltf("dev-zero"), r"face\.gltf: is a character device, not a regular file"
)
add("gltf/file-dangling", top_level_gltf("dangling"), r"face\.gltf: symbolic link to .*gone\.gltf")


def sibling_primitive(change: Callable[[dict], None]) -> Callable[[dict, Path], None]:
    """A second primitive sharing the first one's accessors, changed by ``change``."""

    def mutate(document: dict, folder: Path) -> None:
        primitive = json.loads(json.dumps(document["meshes"][0]["primitives"][0]))
        change(primitive)
        document["meshes"][0]["primitives"].append(primitive)

    return mutate


gltf_case(
    "sibling-fewer-targets",
    sibling_primitive(lambda p: p["targets"].pop()),
    r"primitive 1: has 1 morph targets, primitive 0 has 2",
)
gltf_case(
    "sibling-no-targets",
    sibling_primitive(lambda p: p.pop("targets")),
    r"primitive 1: has 0 morph targets, primitive 0 has 2",
)
gltf_case(
    "sibling-other-names",
    sibling_primitive(lambda p: p.update(extras={"targetNames": ["x", "y"]})),
    r"primitive 1: its morph targets are named differently",
)
gltf_case(
    "sibling-lines",
    sibling_primitive(lambda p: p.update(mode=1)),
    warning=r"primitive 1: mode 1 \(LINES\) has no triangles; left out",
    check=lambda rig: rig.n_vertices == 6 and rig.provenance.primitives == (0,),
)
gltf_case(
    "second-mesh-with-targets",
    lambda document, folder: (
        document["meshes"].insert(0, json.loads(json.dumps(document["meshes"][0])) | {"name": "Teeth"})
        or document["meshes"][0]["primitives"][0]["targets"].pop()
    ),
    warning=r"only one mesh is read; left out: 'Teeth' \(1 morph target\)",
    check=lambda rig: rig.provenance.mesh == "Face" and rig.names == ("jawOpen", "smile"),
)
