"""Rigs as they come from other tools: stray and seam-split vertices, rounded OBJ coordinates, other neutral
names, eyeball regions instead of eyelids, corrupt archives."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import rigs
from rigs import RigError, mirror_map
from rigs._obj import decimal_step
from rigs._warp import locate


@pytest.fixture(scope="module")
def tiny() -> rigs.Rig:
    return rigs.generate("tiny")


def _mirrors_exactly(points: np.ndarray, mirror: np.ndarray, count: int) -> bool:
    """The first ``count`` vertices map to a vertex at their reflection across x = 0."""
    return bool(np.allclose(points[mirror[:count]], points[:count] * [-1, 1, 1], atol=1e-9))


@pytest.mark.parametrize(
    "strays",
    [
        np.array([[1e3, 0.0, 0.0]]),  # one unreferenced vertex far off
        np.full((40, 3), 500.0),  # a pile of stray points at one place
        500.0 + np.random.default_rng(0).random((25, 3)) * 30,  # a loose asymmetric part
        np.zeros((5, 3)),  # exporter leftovers at the origin
    ],
)
def test_mirror_map_is_not_thrown_off_by_stray_vertices(tiny, strays) -> None:
    points = np.concatenate([tiny.neutral, strays])
    mirror = mirror_map(points)
    assert (mirror[: tiny.n_vertices] >= 0).all()
    assert _mirrors_exactly(points, mirror, tiny.n_vertices)


def test_mirror_map_counts_seam_duplicates_once(tiny) -> None:
    # glTF exporters split vertices along UV seams; here only the left side is split.
    left = np.flatnonzero(tiny.neutral[:, 0] > 0.5)
    points = np.concatenate([tiny.neutral, tiny.neutral[left]])
    mirror = mirror_map(points)
    assert (mirror >= 0).all()
    assert _mirrors_exactly(points, mirror, len(points))


def test_mirror_plane_is_fitted_on_a_sample_of_a_large_inexact_mesh() -> None:
    # Over 4096 vertices the plane is fitted on a sample; a mesh that is not exactly symmetric takes
    # that path (it used to index the sample with indices of the whole mesh).
    generator = np.random.default_rng(1)
    half = generator.normal(size=(3000, 3)) * [0.6, 1.0, 0.4]
    half[:, 0] = np.abs(half[:, 0]) + 0.05
    other = half * [-1, 1, 1]
    other[::2, 0] += 1e-3  # a capture: one side off by a little
    points = np.concatenate([half, other]) + [2.0, 0.0, 0.0]
    mirror = mirror_map(points)
    assert np.mean(mirror[: len(half)] == np.arange(len(half)) + len(half)) > 0.9


def test_warp_finds_the_eyes_from_eyeball_regions(tiny) -> None:
    # MakeHuman heads (Face Units) have eyeball groups eye_L / eye_R, no eyelid regions.
    eyes = {
        side: np.union1d(tiny.regions[f"upper_eyelid_{side}"], tiny.regions[f"lower_eyelid_{side}"])
        for side in ("L", "R")
    }
    rig = replace(tiny, regions={f"eye_{side}": indices for side, indices in eyes.items()}, landmarks={})
    np.testing.assert_allclose(locate(rig, "eye_L"), tiny.neutral[eyes["L"]].mean(axis=0))
    warped = rigs.warp(rig, "big-eyes")
    assert not np.allclose(warped.neutral, rig.neutral)
    bare = replace(rig, regions={})
    with pytest.raises(
        RigError, match=r"cannot locate 'eye_L' .*'upper_eyelid_L' and 'lower_eyelid_L', nor 'eye_L'"
    ):
        rigs.warp(bare, "big-eyes")


def _write(path, vertices, faces, number="%.6f") -> None:
    row = f"v {number} {number} {number}\n"
    text = (
        (row * len(vertices)) % tuple(vertices.ravel())
        if number != "%r"
        else "".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in vertices.tolist())
    )
    path.write_text(text + ("f %d %d %d\n" * len(faces)) % tuple((faces + 1).ravel()))


def test_obj_rounded_to_six_decimals_in_metres_keeps_an_empty_shape_empty(tiny, tmp_path) -> None:
    # Blender and Maya write %.6f; in metres one rounding step is ~5e-6 of a head's diagonal, above the
    # relative noise floor. A shape the artist left untouched but the tool re-evaluated (sub-micron float
    # noise) differs from the neutral by single rounding steps and must still load as empty.
    neutral = tiny.neutral * 0.01
    folder = tmp_path / "blender"
    folder.mkdir()
    _write(folder / "neutral.obj", neutral, tiny.triangles)
    untouched = neutral + np.random.default_rng(3).normal(scale=2e-7, size=neutral.shape)
    _write(folder / "untouched.obj", untouched, tiny.triangles)
    _write(folder / "jawOpen.obj", neutral + 0.01 * tiny.deltas[tiny.index("jawOpen")], tiny.triangles)
    assert np.abs(np.round(untouched, 6) - np.round(neutral, 6)).max() > 0  # rounding steps do differ
    rig = rigs.load(folder)
    assert rig.load_report.noise.rounding_step == pytest.approx(1e-6)
    assert rig.load_report.empty_shapes == ("untouched",)
    assert not rig.deltas[rig.index("untouched")].any()
    moved = np.linalg.norm(0.01 * tiny.deltas[tiny.index("jawOpen")], axis=1) > 2e-6
    assert np.array_equal(np.linalg.norm(rig.deltas[rig.index("jawOpen")], axis=1) > 0, moved)


def test_decimal_step_tells_rounding_from_design_grids() -> None:
    values = np.random.default_rng(2).normal(size=(500, 3))
    assert decimal_step(np.round(values, 6)) == pytest.approx(1e-6)
    assert decimal_step(np.round(values * 1000, 4)) == pytest.approx(1e-4)
    assert decimal_step(values) == 0.0  # full precision: nothing to respect
    assert decimal_step(np.arange(30.0).reshape(10, 3) / 2) == 0.0  # halves: a grid, not rounding


@pytest.mark.parametrize("name", ["Neutral.obj", "Basis.obj", "base.OBJ"])
def test_obj_folder_neutral_under_a_common_name(tiny, tmp_path, name) -> None:
    folder = rigs.save(tiny.subset(tiny.names[:2]), tmp_path / "rig")
    (folder / "rig.json").unlink()
    (folder / "neutral.obj").rename(folder / name)
    assert rigs.load(folder).names == tiny.names[:2]


def test_obj_folder_with_two_candidate_neutrals_is_an_error(tiny, tmp_path) -> None:
    folder = rigs.save(tiny.subset(tiny.names[:1]), tmp_path / "rig")
    (folder / "rig.json").unlink()
    (folder / "neutral.obj").rename(folder / "Basis.obj")
    (folder / "rest.obj").write_text((folder / "Basis.obj").read_text())
    with pytest.raises(
        RigError, match=r"rig: several OBJ files could be the neutral \(Basis\.obj, rest\.obj\)"
    ):
        rigs.load(folder)


def test_the_neutral_obj_path_loads_its_folder(tiny, tmp_path) -> None:
    folder = rigs.save(tiny.subset(tiny.names[:3]), tmp_path / "rig")
    (folder / "rig.json").unlink()
    (folder / "neutral.obj").rename(folder / "head_rest_pose.obj")
    rig = rigs.load(folder / "head_rest_pose.obj")
    assert rig.names == tuple(sorted(tiny.names[:3])) and rig.n_vertices == tiny.n_vertices
    alone = tmp_path / "alone"
    alone.mkdir()
    (alone / "head.obj").write_text((folder / "head_rest_pose.obj").read_text())
    with pytest.raises(
        RigError, match=r"head\.obj: one OBJ holds no blendshapes, and its folder has no other"
    ):
        rigs.load(alone / "head.obj")


def test_a_file_that_is_not_a_zip_is_named_as_such(tmp_path) -> None:
    path = tmp_path / "face.npz"
    path.write_bytes(b"not an archive at all")
    with pytest.raises(RigError, match=r"face\.npz: not a NumPy \.npz archive \(not a zip file") as caught:
        rigs.load(path)
    assert "pickle" not in str(caught.value)


def test_a_shape_with_the_neutrals_face_section_and_one_more_face_is_refused(tiny, tmp_path) -> None:
    # Shape files ending with the neutral's face section skip re-reading it; a face before it still counts.
    folder = rigs.save(tiny.subset(tiny.names[:2]), tmp_path / "rig")
    path = folder / f"{tiny.names[1]}.obj"
    text = path.read_text()
    first_face = text.index("\nf ") + 1
    path.write_text(text[:first_face] + "f 1 2 3\n" + text[first_face:])
    with pytest.raises(
        RigError, match=rf"{tiny.names[1]}\.obj: {tiny.n_triangles + 1} faces, but the neutral"
    ):
        rigs.load(folder)
    path.write_text(text)
    assert rigs.load(folder).names == tiny.names[:2]


def _split_glb(rig: rigs.Rig, path, parts: int = 2):
    """``rig`` as Blender writes a multi-material head: one primitive per material, each with its own copy
    of the vertices it uses and every morph target, target names in the mesh's extras."""
    import pygltflib as gltf

    blob = bytearray()
    views, accessors = [], []

    def add(array: np.ndarray, kind: str, component: int) -> int:
        data = np.ascontiguousarray(array).tobytes()
        views.append(gltf.BufferView(buffer=0, byteOffset=len(blob), byteLength=len(data)))
        blob.extend(data + b"\0" * (-len(data) % 4))
        accessors.append(
            gltf.Accessor(bufferView=len(views) - 1, componentType=component, count=len(array), type=kind)
        )
        return len(accessors) - 1

    primitives = []
    for triangles in np.array_split(rig.triangles, parts):
        used, local = np.unique(triangles, return_inverse=True)
        targets = [{"POSITION": add(d[used].astype(np.float32), "VEC3", gltf.FLOAT)} for d in rig.deltas]
        primitives.append(
            gltf.Primitive(
                attributes=gltf.Attributes(
                    POSITION=add(rig.neutral[used].astype(np.float32), "VEC3", gltf.FLOAT)
                ),
                indices=add(local.astype(np.uint32).ravel(), "SCALAR", gltf.UNSIGNED_INT),
                targets=targets,
            )
        )
    mesh = gltf.Mesh(name="Head", primitives=primitives, extras={"targetNames": list(rig.names)})
    document = gltf.GLTF2(
        scene=0,
        scenes=[gltf.Scene(nodes=[0])],
        nodes=[gltf.Node(mesh=0)],
        meshes=[mesh],
        accessors=accessors,
        bufferViews=views,
        buffers=[gltf.Buffer(byteLength=len(blob))],
    )
    document.set_binary_blob(bytes(blob))
    document.save_binary(str(path))
    return path


def test_gltf_primitives_per_material_are_read_as_one_mesh(tiny, tmp_path) -> None:
    rig = rigs.load(_split_glb(tiny, tmp_path / "head.glb", parts=3))
    assert rig.provenance.primitives == (0, 1, 2) and rig.n_triangles == tiny.n_triangles
    assert rig.names == tiny.names
    welded = rigs.load(tmp_path / "head.glb", weld=True)
    assert welded.n_vertices == tiny.n_vertices
    moved = np.linalg.norm(rig.deltas, axis=2).sum(axis=1)
    np.testing.assert_allclose(
        np.linalg.norm(welded.deltas, axis=2).sum(axis=1),
        np.linalg.norm(tiny.deltas, axis=2).sum(axis=1),
        rtol=1e-5,
    )
    assert (moved >= np.linalg.norm(welded.deltas, axis=2).sum(axis=1) - 1e-6).all()
    assert rigs.load(tmp_path / "head.glb", primitive=1).provenance.primitives == (1,)


def test_a_blendshape_obj_path_is_not_taken_for_the_neutral(tiny, tmp_path) -> None:
    folder = rigs.save(tiny.subset(tiny.names[:2]), tmp_path / "rig")
    shape = folder / f"{tiny.names[0]}.obj"
    with pytest.raises(
        RigError, match=r"not the neutral of its folder \(neutral\.obj is\); load .*neutral\.obj"
    ):
        rigs.load(shape)
    (folder / "rig.json").unlink()
    with pytest.raises(RigError, match=r"not the neutral of its folder \(neutral\.obj is\)"):
        rigs.load(shape)
    assert rigs.load(folder / "neutral.obj").n_shapes == 2
