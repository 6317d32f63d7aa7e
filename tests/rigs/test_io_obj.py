"""OBJ reading (real-world export quirks), triangulation, and rigs as folders of OBJs."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import rigs
from rigs import Rig, RigError
from rigs._obj import parse_obj
from rigs._triangulate import triangulate

# A 3 x 2 grid of quads: 12 vertices, 6 quads.
GRID = np.array([[x, y, 0.0] for y in range(3) for x in range(4)], dtype=float)
QUADS = [
    np.array([y * 4 + x, y * 4 + x + 1, (y + 1) * 4 + x + 1, (y + 1) * 4 + x])
    for y in range(2)
    for x in range(3)
]


def obj_text(vertices, faces, *, header="") -> str:
    lines = [header] if header else []
    lines += ["v " + " ".join(repr(float(c)) for c in vertex) for vertex in vertices]
    lines += ["f " + " ".join(str(i + 1) for i in face) for face in faces]
    return "\n".join(lines) + "\n"


def write_folder(folder, shapes: dict, *, neutral=GRID, faces=QUADS):
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "neutral.obj").write_text(obj_text(neutral, faces))
    for name, positions in shapes.items():
        (folder / f"{name}.obj").write_text(obj_text(positions, faces))
    return folder


def moved(index, offset):
    positions = GRID.copy()
    positions[index] += offset
    return positions


# -- reader ------------------------------------------------------------------------------------------------
def test_reader_handles_real_export_quirks():
    text = (
        "# exported\r\n"
        "mtllib face.mtl\r\n"
        "o Head\r\n"
        "v 0 0 0 1.0\r\n"  # w coordinate
        "v 1.0e0 0 0 0.5 0.5 0.5\r\n"  # vertex colours
        "v 1 1 \\\r\n 0\r\n"  # line continuation
        "v -1E-3 1 0 # inline comment\r\n"
        "vt 0 0\r\nvt 1 0\r\nvt 1 1\r\nvt 0 1\r\nvt 0.5 0.5\r\n"  # more vt than v: seams
        "vn 0 0 1\r\n"
        "g skin lips\r\n"
        "usemtl skin\r\n"
        "s 1\r\n"
        "f 1/1/1 2/2/1 3/3/1\r\n"
        "g teeth\r\n"
        "s off\r\n"
        "f -4//1 -2//1 -1//1\r\n"  # negative indices, v//vn
        "f 1/5 3/3 4/4\r\n"
        "l 1 2\r\n"
    )
    mesh = parse_obj(text, "quirks.obj")
    np.testing.assert_allclose(mesh.vertices, [[0, 0, 0], [1, 0, 0], [1, 1, 0], [-1e-3, 1, 0]])
    assert [face.tolist() for face in mesh.faces] == [[0, 1, 2], [0, 2, 3], [0, 2, 3]]
    assert {name: idx.tolist() for name, idx in mesh.groups.items()} == {
        "skin": [0],
        "lips": [0],
        "teeth": [1, 2],
    }
    np.testing.assert_array_equal(mesh.group_vertices("teeth"), [0, 2, 3])


@pytest.mark.parametrize(
    "text",
    [
        obj_text(GRID, QUADS),
        obj_text(GRID, QUADS).replace("\n", "\r\n").replace("f ", "f\t"),
        obj_text(GRID, QUADS).replace("v 0.0", "  v 0.0").replace("\nf ", " # c\nf "),
        obj_text(GRID, QUADS).replace("v 1.0 0.0 0.0", "v 1.0 0.0 0.0 1.0"),
    ],
)
def test_vertex_only_reading_agrees_with_full_reading(text):
    full = parse_obj(text, "a.obj")
    fast = parse_obj(text, "a.obj", with_faces=False)
    np.testing.assert_array_equal(fast.vertices, full.vertices)
    assert fast.face_digest == full.face_digest and len(fast.faces) == 0 and len(full.faces) == len(QUADS)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("v 0 0\n", r"bad\.obj:1: vertex needs x y z, got 'v 0 0'"),
        ("v 0 0 0\nv 1 x 0\n", r"bad\.obj:2: vertex has a non-numeric coordinate: 'v 1 x 0'"),
        ("v 0 0 0\nv 1 nan 0\n", r"bad\.obj:2: vertex 1 has a non-finite coordinate"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", r"bad\.obj:4: face needs at least 3 corners"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", r"bad\.obj:4: face indexes a vertex outside 1\.\.3"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", r"bad\.obj:4: face indexes a vertex outside 1\.\.3"),
        ("v 0 0 0\nv 1 0 0\nf -1 -2 -3\nv 0 1 0\n", r"bad\.obj:3: face indexes a vertex outside"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 a/1\n", r"bad\.obj:4: face has a malformed vertex index"),
        ("# nothing\n", r"bad\.obj: no vertices"),
        ("v 0 0 \\\n 0\nv 1 \\\n 0 0\nv 0 1\n", r"bad\.obj:5: vertex needs x y z"),
    ],
)
def test_reader_errors_name_file_and_line(text, message):
    with pytest.raises(RigError, match=message) as caught:
        parse_obj(text, "bad.obj")
    assert "\n" not in str(caught.value)


# -- triangulation ------------------------------------------------------------------------------------------
def signed_normals(vertices, triangles):
    a, b, c = (vertices[triangles[:, i]] for i in range(3))
    return np.cross(b - a, c - a)


def test_quads_split_on_a_diagonal_that_keeps_both_halves_facing_up():
    convex = np.array([[0, 0, 0], [2, 0, 0], [2, 2, 0], [0, 2, 0]], dtype=float)
    np.testing.assert_array_equal(triangulate([np.arange(4)], convex), [[0, 1, 2], [0, 2, 3]])
    dart = np.array([[0, 0, 0], [2, 1, 0], [4, 0, 0], [2, 4, 0]], dtype=float)  # reflex corner 1
    triangles = triangulate([np.arange(4)], dart)
    assert (signed_normals(dart, triangles)[:, 2] > 0).all()
    np.testing.assert_array_equal(triangles, [[0, 1, 3], [1, 2, 3]])


def polygon_area(points):
    x, y = points[:, 0], points[:, 1]
    return 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def test_concave_ngon_is_ear_clipped_and_triangles_keep_face_order():
    l_shape = np.array([[0, 0, 0], [3, 0, 0], [3, 1, 0], [1, 1, 0], [1, 3, 0], [0, 3, 0]], dtype=float)
    faces = [np.array([0, 1, 2]), np.arange(6)]
    triangles = triangulate(faces, l_shape)
    assert len(triangles) == 1 + 4
    np.testing.assert_array_equal(triangles[0], [0, 1, 2])
    normals = signed_normals(l_shape, triangles[1:])
    assert (normals[:, 2] > 0).all()
    assert 0.5 * normals[:, 2].sum() == pytest.approx(polygon_area(l_shape))


def test_convex_ngon_is_fanned():
    angles = np.linspace(0, 2 * np.pi, 7)[:-1]
    hexagon = np.stack([np.cos(angles), np.sin(angles), np.zeros(6)], axis=1)
    np.testing.assert_array_equal(triangulate([np.arange(6)], hexagon)[:, 0], [0, 0, 0, 0])


@settings(max_examples=60, deadline=None)
@given(
    radii=st.lists(st.floats(0.2, 1.0), min_size=5, max_size=12),
    tilt=st.floats(-1.0, 1.0),
    reverse=st.booleans(),
)
def test_star_polygons_triangulate_without_flips_and_cover_their_area(radii, tilt, reverse):
    angles = np.linspace(0, 2 * np.pi, len(radii) + 1)[:-1]
    flat = np.stack([np.cos(angles) * radii, np.sin(angles) * radii], axis=1)
    if reverse:
        flat = flat[::-1]
    rotation = np.array([[1, 0, 0], [0, np.cos(tilt), -np.sin(tilt)], [0, np.sin(tilt), np.cos(tilt)]])
    points = np.column_stack([flat, np.zeros(len(flat))]) @ rotation.T
    triangles = triangulate([np.arange(len(points))], points)
    assert len(triangles) == len(points) - 2
    normals = signed_normals(points, triangles)
    facing = normals @ normals.sum(axis=0)
    assert (facing > -1e-12).all()
    assert 0.5 * np.linalg.norm(normals, axis=1).sum() == pytest.approx(polygon_area(flat), rel=1e-9)


# -- folders -----------------------------------------------------------------------------------------------
def test_folder_gives_deltas_names_from_stems_and_keeps_quads(tmp_path):
    folder = write_folder(tmp_path / "rig", {"smile": moved(5, [0, 0, 0.3]), "blink": moved(6, [0, -0.2, 0])})
    rig = rigs.load(folder)
    assert rig.names == ("blink", "smile")
    np.testing.assert_allclose(rig.deltas[1, 5], [0, 0, 0.3])
    assert np.count_nonzero(rig.deltas) == 2
    assert rig.n_triangles == 12 and len(rig.faces) == 6
    assert rig.provenance.format == "obj-folder" and rig.provenance.units == "unknown"
    assert rig.surface.obj == folder / "neutral.obj" and rig.surface.folder == folder
    assert rigs.rig_surface(rig).n_vertices == rig.n_vertices


@pytest.mark.parametrize("marked", ["neutral", "smile", "every file"])
def test_a_byte_order_mark_is_no_part_of_the_first_line(tmp_path, marked):
    """Windows editors start UTF-8 files with a byte-order mark: the first line (a vertex, or ``mtllib``)
    is read as without it, and the surface the session writes from carries no mark either."""
    plain = rigs.load(write_folder(tmp_path / "plain", {"smile": moved(5, [0, 0, 0.3])}))
    folder = write_folder(tmp_path / "marked", {"smile": moved(5, [0, 0, 0.3])})
    for name in ("neutral", "smile"):
        if marked in (name, "every file"):
            path = folder / f"{name}.obj"
            header = "mtllib face.mtl\n" if name == "neutral" else ""
            path.write_bytes(b"\xef\xbb\xbf" + (header + path.read_text()).encode())
    rig = rigs.load(folder)
    np.testing.assert_array_equal(rig.neutral, plain.neutral)
    np.testing.assert_array_equal(rig.deltas, plain.deltas)
    assert all("\ufeff" not in line for line in rigs.rig_surface(rig).lines)


def test_round_trip_through_writer_keeps_order_regions_units_and_faces(tmp_path):
    generator = np.random.default_rng(3)
    rig = Rig(
        neutral=GRID + generator.normal(scale=0.01, size=GRID.shape),
        deltas=generator.normal(scale=0.1, size=(3, 12, 3)),
        triangles=triangulate(QUADS, GRID),
        names=("zeta", "alpha", "mid"),
        regions={"upper_lip": [1, 2], "lower_lip": [9]},
        faces=tuple(QUADS),
        provenance=rigs.Provenance(source="generated", units="cm"),
    )
    loaded = rigs.load(rigs.save(rig, tmp_path / "out"))
    assert loaded.names == rig.names
    np.testing.assert_array_equal(loaded.neutral, rig.neutral)
    np.testing.assert_allclose(loaded.deltas, rig.deltas, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(loaded.triangles, rig.triangles)
    assert [f.tolist() for f in loaded.faces] == [f.tolist() for f in QUADS]
    assert {k: v.tolist() for k, v in loaded.regions.items()} == {"upper_lip": [1, 2], "lower_lip": [9]}
    assert loaded.provenance.units == "cm"
    assert rigs.load(tmp_path / "out" / "rig.json").names == rig.names


def test_noise_below_the_floor_is_zeroed_and_reported(tmp_path):
    generator = np.random.default_rng(0)
    jitter = generator.uniform(-1e-8, 1e-8, size=GRID.shape)  # far below 1e-6 of the diagonal
    shapes = {"jaw": moved(9, [0, -0.5, 0]) + jitter, "still": GRID + jitter}
    rig = rigs.load(write_folder(tmp_path / "noisy", shapes))
    assert np.count_nonzero(np.linalg.norm(rig.deltas[rig.index("jaw")], axis=1)) == 1
    assert rig.load_report.empty_shapes == ("still",)
    assert rig.load_report.noise.zeroed["still"] == 12
    assert rig.load_report.noise.zeroed["jaw"] == 11
    assert rig.load_report.noise.floor == pytest.approx(1e-6 * np.linalg.norm([3, 2, 0]))
    kept = rigs.load(tmp_path / "noisy", noise_floor=0)
    assert kept.load_report.empty_shapes == () and np.count_nonzero(kept.deltas[kept.index("still")]) > 0


def test_empty_blendshape_is_kept_and_listed(tmp_path):
    rig = rigs.load(write_folder(tmp_path / "r", {"neutralCopy": GRID, "raise": moved(0, [0, 0, 1])}))
    assert rig.names == ("neutralCopy", "raise") and rig.load_report.empty_shapes == ("neutralCopy",)


def test_named_neutral_and_shapes_with_other_uv_indices_or_no_faces(tmp_path):
    folder = tmp_path / "r"
    folder.mkdir()
    (folder / "base.obj").write_text(obj_text(GRID, QUADS))
    uv_faces = "".join(f"vt 0 0\nf {a + 1}/1 {b + 1}/1 {c + 1}/1 {d + 1}/1\n" for a, b, c, d in QUADS)
    (folder / "uv.obj").write_text(obj_text(moved(1, [0.1, 0, 0]), []) + uv_faces)
    (folder / "points.obj").write_text(obj_text(moved(2, [0.2, 0, 0]), []))
    rig = rigs.load(folder, neutral="base")
    assert rig.names == ("points", "uv")
    np.testing.assert_allclose(rig.deltas[:, [1, 2], 0], [[0, 0.2], [0.1, 0]])


def test_missing_folder_and_missing_neutral(tmp_path):
    with pytest.raises(RigError, match=r"nowhere: no such file or folder"):
        rigs.load(tmp_path / "nowhere")
    folder = tmp_path / "r"
    folder.mkdir()
    (folder / "head.obj").write_text(obj_text(GRID, QUADS))
    with pytest.raises(
        RigError,
        match=r"neutral\.obj: neutral mesh not found \(pass neutral=NAME, or load the neutral OBJ's path\); "
        r"OBJ files here: head\.obj",
    ):
        rigs.load(folder)


def test_mismatched_vertex_count_names_the_file(tmp_path):
    folder = write_folder(tmp_path / "r", {"a": moved(0, [0, 0, 1]), "b": GRID[:-1]})
    with pytest.raises(RigError, match=r"b\.obj: 11 vertices, but the neutral neutral\.obj has 12$"):
        rigs.load(folder)


def test_first_file_with_other_connectivity_is_named(tmp_path):
    folder = write_folder(tmp_path / "r", {"a": GRID, "b": GRID, "c": GRID})
    for name in ("c", "b"):
        faces = [face[::-1] for face in QUADS]
        (folder / f"{name}.obj").write_text(obj_text(GRID, faces))
    with pytest.raises(
        RigError, match=r"b\.obj: connectivity differs from the neutral neutral\.obj at face 0"
    ):
        rigs.load(folder)
    (folder / "b.obj").write_text(obj_text(GRID, QUADS[:-1]))
    with pytest.raises(RigError, match=r"b\.obj: 5 faces, but the neutral neutral\.obj has 6"):
        rigs.load(folder)


def test_nan_in_a_blendshape_names_file_and_line(tmp_path):
    folder = write_folder(tmp_path / "r", {"a": GRID})
    (folder / "a.obj").write_text(obj_text(GRID, QUADS).replace("v 1.0 0.0 0.0", "v 1.0 nan 0.0"))
    with pytest.raises(RigError, match=r"a\.obj:2: vertex 1 has a non-finite coordinate"):
        rigs.load(folder)


def test_duplicate_names_from_stems_differing_in_suffix_case(tmp_path):
    folder = write_folder(tmp_path / "r", {"smile": GRID})
    (folder / "smile.OBJ").write_text(obj_text(GRID, QUADS))
    with pytest.raises(RigError, match=r"duplicate blendshape name 'smile'"):
        rigs.load(folder)


def test_duplicate_name_in_manifest(tmp_path):
    folder = write_folder(tmp_path / "r", {"smile": GRID})
    (folder / "rig.json").write_text(json.dumps({"shapes": ["smile", "smile"]}))
    with pytest.raises(RigError, match=r"rig\.json: duplicate blendshape name 'smile'"):
        rigs.load(folder)


def test_single_obj_is_not_a_rig(tmp_path):
    path = tmp_path / "head.obj"
    path.write_text(obj_text(GRID, QUADS))
    with pytest.raises(RigError, match=r"head\.obj: one OBJ holds no blendshapes"):
        rigs.load(path)


@pytest.mark.parametrize(
    ("names", "message"),
    [
        (("a/b",), r"blendshape name 'a/b' cannot be an OBJ file name"),
        (("neutral",), r"blendshape name 'neutral' collides with 'neutral'"),
        (("Smile", "smile"), r"blendshape name 'smile' collides with 'Smile'"),
    ],
)
def test_writer_refuses_names_that_are_not_file_names(tmp_path, names, message):
    rig = Rig(
        neutral=GRID, deltas=np.zeros((len(names), 12, 3)), triangles=triangulate(QUADS, GRID), names=names
    )
    with pytest.raises(RigError, match=message):
        rigs.save(rig, tmp_path / "out")


def test_writer_refuses_a_folder_with_other_objs_and_single_obj_targets(tmp_path):
    rig = Rig(neutral=GRID, deltas=np.zeros((1, 12, 3)), triangles=triangulate(QUADS, GRID), names=("a",))
    folder = write_folder(tmp_path / "busy", {"other": GRID})
    with pytest.raises(RigError, match=r"busy: already holds other OBJ files \(other\.obj\)"):
        rigs.save(rig, folder)
    with pytest.raises(RigError, match=r"rig\.obj: cannot save as '\.obj'"):
        rigs.save(rig, tmp_path / "rig.obj")


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**20), scale=st.sampled_from([1e-3, 1.0, 1e4]), n_shapes=st.integers(0, 3))
def test_obj_folder_round_trip_property(tmp_path_factory, seed, scale, n_shapes):
    generator = np.random.default_rng(seed)
    neutral = (GRID + generator.normal(scale=0.1, size=GRID.shape)) * scale
    rig = Rig(
        neutral=neutral,
        deltas=generator.normal(scale=0.05 * scale, size=(n_shapes, 12, 3)),
        triangles=triangulate(QUADS, neutral),
        names=tuple(f"shape {k}" for k in range(n_shapes)),
        faces=tuple(QUADS),
    )
    loaded = rigs.load(rigs.save(rig, tmp_path_factory.mktemp("objs") / "rig"), noise_floor=0)
    np.testing.assert_array_equal(loaded.neutral, rig.neutral)
    np.testing.assert_allclose(loaded.deltas, rig.deltas, rtol=0, atol=4 * np.finfo(float).eps * scale * 4)
    assert loaded.names == rig.names


def test_shapes_in_one_subfolder_beside_the_neutral_are_read(tmp_path):
    flat = rigs.load(write_folder(tmp_path / "flat", {"b": moved(1, (0, 0, 1)), "a": moved(4, (0, 1, 0))}))
    nested = tmp_path / "nested"
    write_folder(nested / "shapes", {"b": moved(1, (0, 0, 1)), "a": moved(4, (0, 1, 0))})
    (nested / "shapes" / "neutral.obj").rename(nested / "neutral.obj")
    (nested / "textures").mkdir()  # a subfolder without OBJs is not a candidate
    rig = rigs.load(nested)
    assert rig.names == flat.names == ("a", "b")
    np.testing.assert_array_equal(rig.deltas, flat.deltas)


def test_two_subfolders_of_shapes_are_refused_by_name(tmp_path):
    for sub in ("shapes", "old_shapes"):
        write_folder(tmp_path / sub, {"a": moved(4, (0, 1, 0))})
        (tmp_path / sub / "neutral.obj").unlink()
    (tmp_path / "neutral.obj").write_text(obj_text(GRID, QUADS))
    with pytest.raises(RigError, match="its subfolders old_shapes, shapes all hold OBJ files"):
        rigs.load(tmp_path)
    lone = tmp_path / "lone"
    lone.mkdir()
    (lone / "neutral.obj").write_text(obj_text(GRID, QUADS))
    with pytest.raises(RigError, match="no other OBJ files and no subfolder of them"):
        rigs.load(lone)
    (lone / "shapes").symlink_to(tmp_path / "shapes")  # (a link is never followed: it may lead anywhere)
    with pytest.raises(RigError, match=r"no subfolder of them \(symbolic links are not followed: shapes\)"):
        rigs.load(lone)
