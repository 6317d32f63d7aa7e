"""glTF 2.0 / GLB morph targets from files written here with pygltflib, sparse and quantised included."""

from __future__ import annotations

import base64
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from pygltflib import (
    GLTF2,
    Accessor,
    AccessorSparseIndices,
    AccessorSparseValues,
    Asset,
    Attributes,
    Buffer,
    BufferView,
    Material,
    Mesh,
    Node,
    PbrMetallicRoughness,
    Primitive,
    Scene,
    Sparse,
)
from scipy.spatial.transform import Rotation

import rigs
from rigs import RigError
from rigs._gltf_buffers import dequantise
from rigs._gltf_weld import weld_seams
from rigs._rig import RigWarning

FLOAT, UINT, SHORT, USHORT = 5126, 5125, 5122, 5123

NEUTRAL = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0], [2, 1, 0]], dtype=np.float32)
TRIANGLES = np.array([[0, 1, 2], [0, 2, 3], [1, 4, 5], [1, 5, 2]], dtype=np.uint32)


def target_deltas() -> np.ndarray:
    deltas = np.zeros((3, 6, 3), dtype=np.float32)
    deltas[0, 2] = [0.0, 0.25, 0.5]
    deltas[1, [4, 5]] = [0.0, 0.0, -0.125]
    return deltas  # the third target is empty


class Builder:
    """Packs arrays into one binary buffer and records bufferViews and accessors."""

    def __init__(self) -> None:
        self.gltf = GLTF2(asset=Asset(version="2.0"), scenes=[Scene(nodes=[0])], scene=0)
        self.blob = b""

    def view(self, array: np.ndarray) -> int:
        self.blob += b"\0" * (-len(self.blob) % 4)
        data = np.ascontiguousarray(array).tobytes()
        self.gltf.bufferViews.append(BufferView(buffer=0, byteOffset=len(self.blob), byteLength=len(data)))
        self.blob += data
        return len(self.gltf.bufferViews) - 1

    def accessor(self, array: np.ndarray, kind: str, component: int, *, normalized: bool = False) -> int:
        accessor = Accessor(
            bufferView=self.view(array),
            componentType=component,
            count=len(array),
            type=kind,
            normalized=normalized,
        )
        if kind == "VEC3" and component == FLOAT and np.isfinite(array).all():
            accessor.min, accessor.max = array.min(axis=0).tolist(), array.max(axis=0).tolist()
        self.gltf.accessors.append(accessor)
        return len(self.gltf.accessors) - 1

    def sparse_accessor(self, delta: np.ndarray) -> int:
        moved = np.flatnonzero(np.abs(delta).sum(axis=1)).astype(np.uint32)
        sparse = Sparse(
            count=len(moved),
            indices=AccessorSparseIndices(bufferView=self.view(moved), componentType=UINT),
            values=AccessorSparseValues(bufferView=self.view(delta[moved].astype(np.float32))),
        )
        self.gltf.accessors.append(
            Accessor(
                componentType=FLOAT,
                count=len(delta),
                type="VEC3",
                sparse=sparse,
                min=[0, 0, 0],
                max=[0, 0, 0],
            )
        )
        return len(self.gltf.accessors) - 1

    def mesh(
        self, name, neutral, deltas, triangles, *, names=None, names_on="mesh", sparse=(), quantise=False
    ):
        if quantise:
            position = self.accessor(
                np.round(neutral * 32767).astype(np.int16), "VEC3", SHORT, normalized=True
            )
        else:
            position = self.accessor(neutral.astype(np.float32), "VEC3", FLOAT)
        targets = []
        for k, delta in enumerate(deltas):
            index = self.sparse_accessor(delta) if k in sparse else self.accessor(delta, "VEC3", FLOAT)
            targets.append(Attributes(POSITION=index))
        primitive = Primitive(
            attributes=Attributes(POSITION=position),
            indices=self.accessor(triangles.ravel().astype(np.uint32), "SCALAR", UINT),
            targets=targets,
        )
        names = list(names) if names is not None else [f"shape{k}" for k in range(len(deltas))]
        mesh = Mesh(name=name, primitives=[primitive])
        (mesh if names_on == "mesh" else primitive).extras = {"targetNames": names}
        self.gltf.meshes.append(mesh)
        return primitive

    def save(self, path, *, how="glb"):
        self.gltf.buffers = [Buffer(byteLength=len(self.blob))]
        if not self.gltf.nodes:
            self.gltf.nodes = [Node(mesh=0)]
        if how == "glb":
            self.gltf.set_binary_blob(self.blob)
            self.gltf.save_binary(str(path))
        elif how == "data-uri":
            self.gltf.buffers[0].uri = (
                "data:application/octet-stream;base64," + base64.b64encode(self.blob).decode()
            )
            path.write_text(self.gltf.to_json())
        else:
            self.gltf.buffers[0].uri = "mesh%20data.bin"
            (path.parent / "mesh data.bin").write_bytes(self.blob)
            path.write_text(self.gltf.to_json())
        return path


def simple(tmp_path, how="glb", name="face.glb", **options):
    builder = Builder()
    builder.mesh("Face", NEUTRAL, target_deltas(), TRIANGLES, names=["jawOpen", "smile", "idle"], **options)
    return builder.save(tmp_path / name, how=how)


@pytest.mark.parametrize(
    ("how", "name"), [("glb", "face.glb"), ("data-uri", "face.gltf"), ("bin", "face.gltf")]
)
def test_morph_targets_round_trip_from_every_buffer_kind(tmp_path, how, name):
    rig = rigs.load(simple(tmp_path, how=how, name=name))
    np.testing.assert_array_equal(rig.neutral, NEUTRAL)
    np.testing.assert_array_equal(rig.deltas, target_deltas())
    np.testing.assert_array_equal(rig.triangles, TRIANGLES)
    assert rig.names == ("jawOpen", "smile", "idle")
    assert rig.provenance.units == "m" and rig.provenance.format == "gltf" and rig.provenance.mesh == "Face"
    assert rig.load_report.empty_shapes == ("idle",)


def test_sparse_targets_and_primitive_extras(tmp_path):
    builder = Builder()
    builder.mesh(
        "Face",
        NEUTRAL,
        target_deltas(),
        TRIANGLES,
        names=["a", "b", "c"],
        names_on="primitive",
        sparse=(0, 1, 2),
    )
    rig = rigs.load(builder.save(tmp_path / "sparse.glb"))
    assert builder.gltf.accessors[1].bufferView is None and builder.gltf.accessors[1].sparse.count == 1
    np.testing.assert_array_equal(rig.deltas, target_deltas())
    assert rig.names == ("a", "b", "c")


def test_default_names_when_no_target_names(tmp_path):
    builder = Builder()
    primitive = builder.mesh("Face", NEUTRAL, target_deltas(), TRIANGLES)
    builder.gltf.meshes[0].extras = {}
    assert primitive.extras == {}
    assert rigs.load(builder.save(tmp_path / "anon.glb")).names == ("target_0", "target_1", "target_2")


def test_quantised_positions_with_node_transform(tmp_path):
    builder = Builder()
    scaled = NEUTRAL / 2.0  # stored in [-1, 1] as normalised int16, scaled back by the node
    builder.mesh("Face", scaled, target_deltas(), TRIANGLES, quantise=True)
    builder.gltf.nodes = [
        Node(children=[1], translation=[0.0, 0.0, 5.0]),
        Node(mesh=0, scale=[2.0, 2.0, 2.0]),
    ]
    rig = rigs.load(builder.save(tmp_path / "quantised.glb"))
    np.testing.assert_allclose(rig.neutral, NEUTRAL + [0, 0, 5], atol=2 / 32767)
    np.testing.assert_allclose(rig.deltas, 2 * target_deltas(), atol=1e-12)
    assert rig.provenance.transform == "world matrix of node '1'"
    local = rigs.load(tmp_path / "quantised.glb", transform=False)
    np.testing.assert_allclose(local.neutral, scaled, atol=1 / 32767)


def test_normalised_integers_map_to_unit_range():
    np.testing.assert_array_equal(
        dequantise(np.array([[-128, -127, 0, 127]], dtype=np.int8), True), [[-1, -1, 0, 1]]
    )
    np.testing.assert_array_equal(dequantise(np.array([[0, 255]], dtype=np.uint8), True), [[0, 1]])
    np.testing.assert_array_equal(dequantise(np.array([[0, 65535]], dtype=np.uint16), False), [[0, 65535]])


def test_primitive_option_picks_within_the_mesh(tmp_path):
    builder = Builder()
    builder.mesh("Face", NEUTRAL, target_deltas(), TRIANGLES, names=["a", "b", "c"])
    builder.mesh("Other", NEUTRAL, target_deltas()[:2], TRIANGLES, names=["x", "y"], names_on="primitive")
    builder.gltf.meshes[0].primitives.append(builder.gltf.meshes.pop().primitives[0])
    path = builder.save(tmp_path / "prims.glb")
    # glTF gives every primitive of a mesh the same targets: reading both would drop shapes silently.
    with pytest.raises(
        RigError, match=r"prims\.glb: mesh 'Face' primitive 1: has 2 morph targets, primitive 0 has 3"
    ):
        rigs.load(path)
    assert rigs.load(path, primitive=0).names == ("a", "b", "c")
    assert rigs.load(path, primitive=1).provenance.mesh == "Face"
    assert rigs.load(path, primitive=1).names == ("x", "y")
    with pytest.raises(RigError, match=r"prims\.glb: mesh 'Face' has no primitive 2"):
        rigs.load(path, mesh="Face", primitive=2)


def test_mesh_chosen_by_name_or_by_most_targets(tmp_path):
    builder = Builder()
    builder.mesh("Teeth", NEUTRAL, target_deltas()[:1], TRIANGLES, names=["bite"])
    builder.mesh("Head", NEUTRAL, target_deltas(), TRIANGLES, names=["a", "b", "c"])
    path = builder.save(tmp_path / "two.glb")
    with pytest.warns(
        RigWarning, match=r"two\.glb: only one mesh is read; left out: 'Teeth' \(1 morph target\)"
    ):
        assert rigs.load(path).names == ("a", "b", "c")
    assert rigs.load(path, mesh="Teeth").names == ("bite",)
    assert rigs.load(path, mesh=0).names == ("bite",)
    with pytest.raises(RigError, match=r"two\.glb: no mesh named 'Eyes' \(meshes: 'Teeth', 'Head'\)"):
        rigs.load(path, mesh="Eyes")


def test_welding_merges_split_seam_vertices_whose_deltas_agree():
    neutral = np.vstack([NEUTRAL, NEUTRAL[[1, 2]]])  # vertices 6, 7 duplicate 1, 2 (a UV seam)
    deltas = np.concatenate([target_deltas(), target_deltas()[:, [1, 2]]], axis=1).astype(np.float64)
    triangles = np.array([[0, 1, 2], [0, 2, 3], [6, 4, 5], [6, 5, 7]])
    welded, welded_deltas, welded_triangles, vertex_map = weld_seams(neutral, deltas, triangles)
    np.testing.assert_array_equal(welded, NEUTRAL)
    np.testing.assert_array_equal(welded_deltas, target_deltas())
    np.testing.assert_array_equal(welded_triangles, TRIANGLES)
    np.testing.assert_array_equal(vertex_map, [0, 1, 2, 3, 4, 5, 1, 2])
    deltas[0, 7] += 0.1  # the seam copy of vertex 2 now moves differently: it must stay split
    welded, *_ = weld_seams(neutral, deltas, triangles)
    assert len(welded) == 7


def test_weld_option_through_load(tmp_path):
    neutral = np.vstack([NEUTRAL, NEUTRAL[[1]]])
    deltas = np.concatenate([target_deltas(), target_deltas()[:, [1]]], axis=1)
    triangles = np.array([[0, 1, 2], [0, 2, 3], [6, 4, 5], [6, 5, 2]], dtype=np.uint32)
    builder = Builder()
    builder.mesh("Face", neutral, deltas, triangles)
    rig = rigs.load(builder.save(tmp_path / "seam.glb"), weld=True)
    assert rig.n_vertices == 6 and rig.provenance.weld.merged == 1
    np.testing.assert_array_equal(rig.triangles, TRIANGLES)
    assert rigs.load(tmp_path / "seam.glb").n_vertices == 7


def test_triangle_strip(tmp_path):
    builder = Builder()
    primitive = builder.mesh("Strip", NEUTRAL[:4], target_deltas()[:, :4], TRIANGLES[:1])
    primitive.mode = 5
    primitive.indices = builder.accessor(np.array([0, 1, 3, 2], dtype=np.uint32), "SCALAR", UINT)
    rig = rigs.load(builder.save(tmp_path / "strip.glb"))
    np.testing.assert_array_equal(rig.triangles, [[0, 1, 3], [3, 1, 2]])


UV = np.array([[0.0, 0.0], [0.5, 0.0], [0.5, 0.5], [0.0, 0.5], [1.0, 0.25], [1.0, 0.75]], dtype=np.float32)
NORMALS = np.array(
    [[0, 0, 1], [0, 0.6, 0.8], [0, 0, 1], [0.6, 0, 0.8], [0, 0, 1], [0, 0, 1]], dtype=np.float32
)


def dressed(builder: Builder) -> None:
    """Texture coordinates, normals and a material on the first mesh's primitive, and a second
    primitive (the teeth: normalised 16-bit texture coordinates, no normals, its own material)."""
    skin = builder.gltf.meshes[0].primitives[0]
    skin.attributes.TEXCOORD_0 = builder.accessor(UV, "VEC2", FLOAT)
    skin.attributes.NORMAL = builder.accessor(NORMALS, "VEC3", FLOAT)
    skin.material = 0
    names = builder.gltf.meshes[0].extras["targetNames"]
    builder.mesh("Teeth", NEUTRAL[:3] - [0, 0, 1], target_deltas()[:, :3], TRIANGLES[:1], names=names)
    teeth = builder.gltf.meshes.pop().primitives[0]
    teeth.attributes.TEXCOORD_0 = builder.accessor(
        np.round(UV[:3] * 65535).astype(np.uint16), "VEC2", USHORT, normalized=True
    )
    teeth.material = 1
    builder.gltf.meshes[0].primitives.append(teeth)
    builder.gltf.materials = [
        Material(
            name="Skin Mat", pbrMetallicRoughness=PbrMetallicRoughness(baseColorFactor=[0.9, 0.7, 0.6, 1])
        ),
        Material(name="teeth"),
    ]


def test_texture_coordinates_normals_and_materials_are_kept(tmp_path):
    builder = Builder()
    builder.mesh("Face", NEUTRAL, target_deltas(), TRIANGLES, names=["jawOpen", "smile", "idle"])
    dressed(builder)
    rig = rigs.load(builder.save(tmp_path / "dressed.glb"))
    surface = rig.surface.gltf
    assert rig.n_vertices == 9 and rig.n_triangles == 5
    np.testing.assert_array_equal(surface.corners, rig.triangles)
    np.testing.assert_array_equal(surface.vertex_map, np.arange(9))
    np.testing.assert_array_equal(surface.uvs[:6], UV)
    np.testing.assert_allclose(surface.uvs[6:], UV[:3], atol=1 / 65535)
    np.testing.assert_allclose(surface.normals[:6], NORMALS, atol=1e-7)
    assert np.isnan(surface.normals[6:]).all()  # the teeth have none
    np.testing.assert_array_equal(surface.material, [0, 0, 0, 0, 1])
    assert surface.materials == (("Skin_Mat", pytest.approx((0.9, 0.7, 0.6))), ("teeth", (1.0, 1.0, 1.0)))


def test_normals_follow_the_node_transform_and_survive_welding(tmp_path):
    builder = Builder()
    neutral = np.vstack([NEUTRAL, NEUTRAL[[1]]])  # vertex 6 is a seam copy of vertex 1
    deltas = np.concatenate([target_deltas(), target_deltas()[:, [1]]], axis=1)
    triangles = np.array([[0, 1, 2], [0, 2, 3], [6, 4, 5], [6, 5, 2]], dtype=np.uint32)
    builder.mesh("Face", neutral, deltas, triangles)
    primitive = builder.gltf.meshes[0].primitives[0]
    primitive.attributes.NORMAL = builder.accessor(np.vstack([NORMALS, NORMALS[[1]]]), "VEC3", FLOAT)
    primitive.attributes.TEXCOORD_0 = builder.accessor(
        np.vstack([UV, [[0.9, 0.9]]]).astype(np.float32), "VEC2", FLOAT
    )
    turn = Rotation.from_euler("xyz", [30, -50, 10], degrees=True)
    builder.gltf.nodes = [Node(mesh=0, rotation=turn.as_quat().tolist(), scale=[1.0, 3.0, 0.5])]
    rig = rigs.load(builder.save(tmp_path / "turned.glb"), weld=True)
    surface = rig.surface.gltf
    linear = turn.as_matrix() * [1.0, 3.0, 0.5]
    expected = np.vstack([NORMALS, NORMALS[[1]]]) @ np.linalg.inv(linear)
    np.testing.assert_allclose(
        surface.normals, expected / np.linalg.norm(expected, axis=1, keepdims=True), atol=1e-6
    )
    assert rig.n_vertices == 6 and surface.vertex_map.tolist() == [0, 1, 2, 3, 4, 5, 1]
    np.testing.assert_array_equal(surface.vertex_map[surface.corners], rig.triangles)
    assert surface.corners[2].tolist() == [6, 4, 5]  # the seam copy keeps its own texture coordinates
    np.testing.assert_allclose(surface.uvs[6], [0.9, 0.9])
    assert surface.materials == () and (surface.material == -1).all()


def test_malformed_texture_coordinates_and_materials_are_left_out_with_a_warning(tmp_path):
    builder = Builder()
    builder.mesh("Face", NEUTRAL, target_deltas(), TRIANGLES)
    primitive = builder.gltf.meshes[0].primitives[0]
    primitive.attributes.TEXCOORD_0 = builder.accessor(UV[:4], "VEC2", FLOAT)  # 4 for 6 vertices
    primitive.attributes.NORMAL = builder.accessor(NORMALS[:, :2].copy(), "VEC2", FLOAT)  # not VEC3
    builder.gltf.accessors[primitive.attributes.NORMAL].count = 2**40  # and huge: never allocated
    primitive.material = 3
    with pytest.warns(RigWarning) as caught:
        rig = rigs.load(builder.save(tmp_path / "odd.glb"))
    messages = " | ".join(str(warning.message) for warning in caught)
    assert "TEXCOORD_0: accessor 5 has 4 elements, expected 6; TEXCOORD_0 left out" in messages
    assert "NORMAL: accessor 6 is 'VEC2'" in messages and "NORMAL left out" in messages
    assert "material 3 does not exist (the file has 0); left out" in messages
    assert rig.surface is None
    np.testing.assert_array_equal(rig.neutral, NEUTRAL)


def test_missing_file_and_not_gltf(tmp_path):
    with pytest.raises(RigError, match=r"gone\.glb: no such file or folder"):
        rigs.load(tmp_path / "gone.glb")
    (tmp_path / "junk.gltf").write_text("{ not json")
    with pytest.raises(RigError, match=r"junk\.gltf: not a readable glTF 2\.0 file"):
        rigs.load(tmp_path / "junk.gltf")


def test_missing_external_buffer(tmp_path):
    path = simple(tmp_path, how="bin", name="face.gltf")
    (tmp_path / "mesh data.bin").unlink()
    with pytest.raises(RigError, match=r"face\.gltf: buffer 0 file .*mesh data\.bin is missing"):
        rigs.load(path)


@pytest.mark.parametrize(
    ("extension", "package"),
    [("KHR_draco_mesh_compression", "DracoPy"), ("EXT_meshopt_compression", "gltfpack")],
)
def test_compressed_files_name_the_extension_and_the_decoder(tmp_path, monkeypatch, extension, package):
    monkeypatch.setitem(sys.modules, "almeshopt", None)  # no meshopt decoder installed
    builder = Builder()
    builder.mesh("Face", NEUTRAL, target_deltas(), TRIANGLES)
    builder.gltf.extensionsUsed = [extension]
    builder.gltf.extensionsRequired = [extension]
    path = builder.save(tmp_path / "packed.glb")
    with pytest.raises(RigError, match=rf"packed\.glb: compressed with {extension} \(.*{package}"):
        rigs.load(path)


def test_draco_primitive_without_plain_positions(tmp_path):
    builder = Builder()
    primitive = builder.mesh("Face", NEUTRAL, target_deltas(), TRIANGLES)
    primitive.extensions = {"KHR_draco_mesh_compression": {"bufferView": 0, "attributes": {"POSITION": 0}}}
    builder.gltf.accessors[0].bufferView = None
    with pytest.raises(
        RigError, match=r"mesh 'Face' primitive 0: compressed with KHR_draco_mesh_compression"
    ):
        rigs.load(builder.save(tmp_path / "draco.glb"))


def test_bad_contents_name_file_and_problem(tmp_path):
    builder = Builder()
    builder.mesh("Face", NEUTRAL, target_deltas(), TRIANGLES, names=["a", "b", "a"])
    with pytest.raises(RigError, match=r"dup\.glb: mesh 'Face' primitive 0: duplicate morph target name 'a'"):
        rigs.load(builder.save(tmp_path / "dup.glb"))

    builder = Builder()
    builder.mesh("Face", NEUTRAL, target_deltas(), TRIANGLES, names=["a", "b"])
    with pytest.raises(RigError, match=r"few\.glb: .*extras\.targetNames has 2 names for 3 morph targets"):
        rigs.load(builder.save(tmp_path / "few.glb"))

    builder = Builder()
    builder.mesh("Face", NEUTRAL, target_deltas()[:, :5], TRIANGLES)
    with pytest.raises(RigError, match=r"short\.glb: .*target 0 has 5 positions for 6 vertices"):
        rigs.load(builder.save(tmp_path / "short.glb"))

    builder = Builder()
    deltas = target_deltas()
    deltas[1, 3, 0] = np.nan
    builder.mesh("Face", NEUTRAL, deltas, TRIANGLES)
    with pytest.raises(
        RigError, match=r"nan\.glb: blendshape 'shape1' has a non-finite displacement at vertex 3"
    ):
        rigs.load(builder.save(tmp_path / "nan.glb"))

    builder = Builder()
    builder.mesh("Face", NEUTRAL, target_deltas()[:0], TRIANGLES)
    with pytest.raises(RigError, match=r"none\.glb: no mesh primitive has morph targets"):
        rigs.load(builder.save(tmp_path / "none.glb"))

    builder = Builder()
    builder.mesh("Face", NEUTRAL, target_deltas(), np.array([[0, 1, 9]]))
    with pytest.raises(
        RigError, match=r"range\.glb: mesh 'Face' primitive 0: index 9 is past the 6 vertices"
    ):
        rigs.load(builder.save(tmp_path / "range.glb"))

    builder = Builder()
    builder.mesh("Face", NEUTRAL, target_deltas(), TRIANGLES)
    builder.gltf.bufferViews[0].byteLength -= 4
    with pytest.raises(
        RigError, match=r"cut\.glb: mesh 'Face' primitive 0 POSITION: reads past the end of bufferView 0"
    ):
        rigs.load(builder.save(tmp_path / "cut.glb"))


def test_every_mesh_left_out_is_named_with_its_morph_targets(tmp_path):
    builder = Builder()
    builder.mesh("Eyes", NEUTRAL, np.zeros((0, 6, 3), dtype=np.float32), TRIANGLES)
    builder.mesh("Head", NEUTRAL, target_deltas(), TRIANGLES, names=["a", "b", "c"])
    builder.mesh("Tongue", NEUTRAL, target_deltas()[:2], TRIANGLES, names=["out", "up"])
    path = builder.save(tmp_path / "head.glb")
    with pytest.warns(RigWarning) as caught:
        assert rigs.load(path).names == ("a", "b", "c")
    (message,) = [str(warning.message) for warning in caught if "left out" in str(warning.message)]
    assert "left out: 'Eyes' (no morph targets), 'Tongue' (2 morph targets)" in message


def test_the_command_line_prints_a_reader_warning_as_one_plain_line(tmp_path):
    builder = Builder()
    builder.mesh("Teeth", NEUTRAL, np.zeros((0, 6, 3), dtype=np.float32), TRIANGLES)
    builder.mesh("Head", NEUTRAL, target_deltas(), TRIANGLES, names=["a", "b", "c"])
    path = builder.save(tmp_path / "head.glb")
    root = Path(__file__).resolve().parents[2]
    done = subprocess.run(
        [sys.executable, "-c", "from harness.cli import main; main()", "rigs", "info", str(path)],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(root), "COLUMNS": "200"},
        check=True,
    )
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    left_out = (
        "only one mesh is read; left out: 'Teeth' (no morph targets) "
        "(read another with mesh=NAME: harness rigs convert --mesh NAME)"
    )
    assert lines == [f"warning: {path}: {left_out}"]


def test_the_command_line_converts_the_one_mesh_the_warning_names(tmp_path):
    """What the reader's hint says to do works from the command line: the left-out mesh, by name or
    index, is read into a rig file every command takes."""
    from click.testing import CliRunner

    from harness.cli import cli

    builder = Builder()
    builder.mesh("Teeth", NEUTRAL, target_deltas()[:1], TRIANGLES, names=["bite"])
    builder.mesh("Head", NEUTRAL, target_deltas(), TRIANGLES, names=["a", "b", "c"])
    path = builder.save(tmp_path / "two.glb")
    for mesh, out in (("Teeth", "teeth.npz"), ("0", "first.npz")):
        result = CliRunner().invoke(cli, ["rigs", "convert", str(path), str(tmp_path / out), "--mesh", mesh])
        assert result.exit_code == 0, result.output
        assert rigs.load(tmp_path / out).names == ("bite",)
    result = CliRunner().invoke(cli, ["rigs", "convert", "tiny", str(tmp_path / "t.npz"), "--mesh", "Head"])
    assert (
        result.exit_code == 2
        and "--mesh and --primitive read a glTF or USD file, and this is none" in result.output
    )


def test_primitives_sharing_one_vertex_set_share_its_vertices(tmp_path):
    """One index buffer per material over one POSITION accessor (and the same targets): the vertices are
    read once, as from a single primitive, and each primitive keeps its material."""
    whole = rigs.load(simple(tmp_path, name="whole.glb"))
    builder = Builder()
    first = builder.mesh("Face", NEUTRAL, target_deltas(), TRIANGLES, names=["jawOpen", "smile", "idle"])
    builder.gltf.materials = [Material(name="skin"), Material(name="lips")]
    first.indices = builder.accessor(TRIANGLES[:2].ravel(), "SCALAR", UINT)
    first.material = 0
    second = Primitive(
        attributes=first.attributes,
        indices=builder.accessor(TRIANGLES[2:].ravel(), "SCALAR", UINT),
        targets=first.targets,
        material=1,
    )
    builder.gltf.meshes[0].primitives.append(second)
    split = rigs.load(builder.save(tmp_path / "split.glb"))
    assert split.n_vertices == whole.n_vertices == len(NEUTRAL)
    np.testing.assert_array_equal(split.neutral, whole.neutral)
    np.testing.assert_array_equal(split.deltas, whole.deltas)
    np.testing.assert_array_equal(split.triangles, whole.triangles)
    assert split.provenance.primitives == (0, 1)
    assert split.surface.gltf.material.tolist() == [0, 0, 1, 1]


def test_a_rig_in_inches_is_written_to_gltf_in_metres(tmp_path):
    from dataclasses import replace

    rig = replace(rigs.generate("tiny"), provenance=rigs.Provenance(units="in"))
    (tmp_path / "rig.glb").write_bytes(rigs.glb_bytes(rig))
    glb = rigs.load(tmp_path / "rig.glb", noise_floor=0.0)
    assert glb.provenance.units == "m"
    np.testing.assert_allclose(glb.neutral, rig.neutral * 0.0254, rtol=1e-6, atol=1e-7)
