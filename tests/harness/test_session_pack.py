"""`harness pack` writes a complete scanning session: meshes that keep the source OBJ's own lines, meshes on
the target, a GLB, frontal pictures, the scan sheet, the excluded shapes, fetched rigs by name."""

from __future__ import annotations

import json
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from matplotlib.image import imread
from scipy.spatial.transform import Rotation

import rigs
import session._minimum
from harness.cli import cli, main
from registry._outdir import MANIFEST_NAME
from rigs._faceunits import CACHE_VARIABLE, cached_rig_path, surface_path
from tests.chromium import run_chromium
from tests.harness.cli_helpers import assert_one_line_error

BACKGROUND = np.array([1.0, 1.0, 1.0])


def invoke(*arguments: object):
    return CliRunner(env={"COLUMNS": "250"}).invoke(cli, [str(a) for a in arguments])


def pack(rig: object, out: Path, *extra: object) -> tuple[dict, str]:
    result = invoke("pack", rig, "--out", out, *extra)
    assert result.exit_code == 0, result.output
    return json.loads((out / "expressions.json").read_text()), " ".join(result.output.split())


def lines_of(path: Path, *keywords: str) -> list[str]:
    return [
        line
        for line in path.read_text().splitlines()
        if line.split(None, 1)[:1] and line.split()[0] in keywords
    ]


def positions(path: Path) -> np.ndarray:
    return np.array([line.split()[1:4] for line in lines_of(path, "v")], dtype=float)


def decimals(path: Path) -> int:
    return max(len(value.partition(".")[2]) for line in lines_of(path, "v") for value in line.split()[1:4])


def assert_frontal(picture: Path) -> None:
    """The face fills the centre of the picture's face area, left-right symmetric, taller than wide."""
    image = imread(picture)[..., :3]
    face = image[:, : int(0.62 * image.shape[1])]  # (legend on the right)
    covered = np.abs(face - BACKGROUND).sum(axis=2) > 0.05
    rows, columns = np.nonzero(covered)
    centre = (columns.min() + columns.max()) / 2
    assert abs(centre - face.shape[1] / 2) < 0.08 * face.shape[1]
    assert abs((rows.min() + rows.max()) / 2 - face.shape[0] / 2) < 0.08 * face.shape[0]
    assert np.ptp(rows) > 1.25 * np.ptp(columns)  # a face is far taller than wide only from the front
    box = covered[rows.min() : rows.max() + 1, columns.min() : columns.max() + 1]
    assert (box & box[:, ::-1]).sum() / (box | box[:, ::-1]).sum() > 0.85  # mirror-symmetric silhouette
    tinted = np.ptp(face, axis=2) > 0.15  # coloured shapes (skin and background are near grey)
    assert tinted.any()
    assert abs(np.nonzero(tinted)[1].mean() - centre) < 0.15 * np.ptp(columns)


@pytest.fixture(scope="module")
def faceunits_session(faceunits, tmp_path_factory) -> tuple[Path, dict, str]:
    out = tmp_path_factory.mktemp("faceunits") / "session"
    document, output = pack("faceunits", out, "--jmax", "4")
    return out, document, output


def test_faceunits_session_keeps_the_source_uvs_and_faces(faceunits, faceunits_session) -> None:
    out, document, _ = faceunits_session
    source = Path(faceunits.surface.obj)
    assert source == surface_path()
    uvs, faces = lines_of(source, "vt"), lines_of(source, "f")
    assert len(uvs) > faceunits.n_vertices and len(faces) > 1000  # the base mesh's UVs and quads
    meshes = ["neutral.obj", *(f"expression_{i:02d}.obj" for i in range(1, 5))]
    for name in meshes:
        assert lines_of(out / name, "vt") == uvs and lines_of(out / name, "f") == faces
        assert lines_of(out / name, "g") == lines_of(source, "g")
        assert decimals(out / name) <= 4  # the source's precision, no float noise
    assert np.abs(positions(out / "neutral.obj") - faceunits.neutral).max() < 1e-9
    first = document["expressions"][0]["shapes"]
    posed = faceunits.neutral + faceunits.deltas[faceunits.indices(first)].sum(axis=0)
    assert np.abs(positions(out / "expression_01.obj") - posed).max() <= 0.5e-4 + 1e-12
    reread = rigs.load(out / "neutral.obj", format="obj-folder")  # the session folder is itself a rig
    assert reread.n_shapes == 4 and reread.n_vertices == faceunits.n_vertices


def test_faceunits_session_lists_every_file_and_what_was_left_out(faceunits, faceunits_session) -> None:
    out, document, output = faceunits_session
    written = {p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()} - {MANIFEST_NAME}
    manifest = json.loads((out / MANIFEST_NAME).read_text())["files"]
    assert set(manifest) == written
    assert {"neutral.obj", "session.html", "pictures/expression_04_three_quarter_pose.png"} <= written
    for expression in document["expressions"]:
        assert set(expression["files"]) == {"mesh", "front", "front_pose", "three_quarter_pose"}
        assert set(expression["files"].values()) <= written
    used = {name for e in document["expressions"] for name in e["shapes"]}
    excluded = {entry["shape"]: entry["reason"] for entry in document["excluded"]}
    assert set(excluded) == set(faceunits.names) - used
    rule = "left out by the default constraints: scanned only with jawOpen"
    assert excluded.pop("mouthClose").startswith(rule)
    assert all(reason == "in no expression: --jmax 4 reached" for reason in excluded.values())
    assert document["sequence"]["mode"] == "sequence" and document["sequence"]["jmax"] == 4
    assert f"{len(excluded)} blendshapes in no expression (--jmax 4 reached)" in output


def test_faceunits_pictures_are_frontal(faceunits_session) -> None:
    out, document, _ = faceunits_session
    for expression in document["expressions"]:
        assert_frontal(out / expression["files"]["front"])
        files = expression["files"]
        front, turned = (imread(out / files[key]) for key in ("front_pose", "three_quarter_pose"))
        assert front.shape == turned.shape and not np.array_equal(front, turned)


def test_the_scan_sheet_shows_each_expression_in_the_actors_words(faceunits_session) -> None:
    out, document, _ = faceunits_session
    sheet = (out / "session.html").read_text()
    overview = sheet.split('<section class="session">')[0]
    assert overview.count('<section class="card">') == len(document["expressions"])
    assert sheet.count('<article class="take') == len(document["expressions"])
    for number, expression in enumerate(document["expressions"], start=1):
        assert f"<h2>Expression {number}</h2>" in overview
        for key in ("front", "front_pose", "three_quarter_pose"):
            assert f'src="{expression["files"][key]}"' in overview
    if {"eyeBlinkLeft", "eyeBlinkRight"} <= {name for e in document["expressions"] for name in e["shapes"]}:
        assert "Close both eyes" in sheet
    first = overview.split("<h2>Expression 1</h2>")[1].split("<h2>Expression 2</h2>")[0]
    swatches = re.findall(r"background: (rgb\([0-9,]+\))", first)
    assert len(swatches) == len(set(swatches)) == len(document["expressions"][0]["shapes"])


@pytest.mark.parametrize("preset", ["digidouble", "toon"])
def test_pictures_of_turned_rigs_are_frontal(preset, tmp_path) -> None:
    rig = rigs.generate(preset)
    turn = Rotation.from_euler("xyz", [80, 30, -20], degrees=True).as_matrix()  # e.g. a Z-up export, turned
    turned = replace(rig, neutral=rig.neutral @ turn.T, deltas=rig.deltas @ turn.T)
    path = rigs.save(turned, tmp_path / f"{preset}.npz")
    document, _ = pack(path, tmp_path / "out", "--jmax", "2")
    for expression in document["expressions"]:
        assert_frontal(tmp_path / "out" / expression["files"]["front"])


def obj_rig_folder(tiny: rigs.Rig, folder: Path) -> Path:
    """``tiny`` as a folder of OBJs whose neutral has texture coordinates, normals, groups and materials,
    written with 6 decimals."""
    folder.mkdir()
    faces = tiny.triangles + 1
    head = ["# exported by a DCC", "mtllib face.mtl", "o head"]
    uvs = [f"vt {u:.4f} {v:.4f}" for u, v in tiny.neutral[:, :2] / 20 + 0.5]
    normals = ["vn 0 0 1"]
    groups = ["g skin", "usemtl skin", "s 1"]
    face_lines = [f"f {a}/{a}/1 {b}/{b}/1 {c}/{c}/1" for a, b, c in faces]
    face_lines.insert(len(face_lines) // 2, "g lips")
    face_lines.insert(len(face_lines) // 2 + 1, "usemtl lips")

    def write(path: Path, vertices: np.ndarray) -> None:
        vs = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in vertices]
        path.write_text("\n".join([*head, *vs, *uvs, *normals, *groups, *face_lines]) + "\n")

    write(folder / "neutral.obj", tiny.neutral)
    for name, delta in zip(tiny.names, tiny.deltas, strict=True):
        write(folder / f"{name}.obj", tiny.neutral + delta)
    return folder


def test_an_obj_rig_keeps_every_line_but_the_positions_also_on_the_target(tmp_path) -> None:
    tiny = rigs.generate("tiny")
    folder = obj_rig_folder(tiny, tmp_path / "face")
    source = (folder / "neutral.obj").read_text().splitlines()
    target = tmp_path / "target.obj"
    wider = np.round(tiny.neutral * [1.2, 1.0, 1.0], 6)
    target.write_text(
        "# the actor\n" + "".join(f"v {x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in wider) + "f 1 2 3\n"
    )
    out = tmp_path / "out"
    document, _ = pack(folder, out, "--target", target, "--no-pictures", "--jmax", "3")
    assert document["target"] == str(target)
    rig = rigs.load(folder)
    for index, expression in enumerate(document["expressions"], start=1):
        name = f"expression_{index:02d}.obj"
        text = (out / name).read_text().splitlines()
        assert [line for line in text if not line.startswith(("v ", "# expression"))] == [
            line for line in source if not line.startswith("v ")
        ]
        assert decimals(out / name) <= 6
        delta = rig.deltas[rig.indices(expression["shapes"])].sum(axis=0)
        assert np.abs(positions(out / name) - (rig.neutral + delta)).max() <= 0.5e-6 + 1e-12
        on_target = out / "on_target" / name
        assert expression["files"]["on_target"] == f"on_target/{name}"
        assert np.abs(positions(on_target) - (wider + delta)).max() <= 0.5e-6 + 1e-12
        assert lines_of(on_target, "f") == ["f 1 2 3"]  # the target OBJ's own lines
    assert not (out / "pictures").exists() and (out / "session.html").is_file()


def dressed_gltf(path: Path) -> dict[str, np.ndarray]:
    """A glTF of two primitives with the same two morph targets: the skin (texture coordinates, normals,
    material "Skin") and the teeth (texture coordinates only, no material). Returns its arrays."""
    import base64
    import json as json_module

    skin = np.array([[x, y, 0.1 * x * x] for y in (0.0, 1.0) for x in (-1.0, 0.0, 1.0)], dtype=np.float32)
    teeth = np.array([[-0.3, -0.2, -0.1], [0.3, -0.2, -0.1], [0.0, 0.1, -0.1]], dtype=np.float32)
    arrays = {
        "skin": skin,
        "skin_uv": np.array(
            [[0.1, 0.9], [0.5, 0.9], [0.9, 0.9], [0.1, 0.1], [0.5, 0.1], [0.9, 0.125]], np.float32
        ),
        "skin_normal": np.tile(np.array([0.0, 0.0, 1.0], np.float32), (6, 1)),
        "skin_jaw": np.array([[0, -0.2, 0]] * 3 + [[0, 0, 0]] * 3, np.float32),
        "skin_smile": np.array([[0, 0, 0]] * 3 + [[-0.1, 0.1, 0], [0, 0, 0], [0.1, 0.1, 0]], np.float32),
        "skin_faces": np.array([0, 1, 4, 0, 4, 3, 1, 2, 5, 1, 5, 4], np.uint32),
        "teeth": teeth,
        "teeth_uv": np.array([[0.0, 1.0], [0.25, 1.0], [0.125, 0.75]], np.float32),
        "teeth_jaw": np.array([[0, -0.2, 0]] * 3, np.float32),
        "teeth_smile": np.zeros((3, 3), np.float32),
        "teeth_faces": np.array([0, 1, 2], np.uint32),
    }
    blob, views, accessors = b"", [], []
    for array in arrays.values():
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": array.nbytes})
        kind = "SCALAR" if array.ndim == 1 else f"VEC{array.shape[1]}"
        accessor = {"bufferView": len(views) - 1, "componentType": 5125 if array.ndim == 1 else 5126}
        accessor |= {"count": len(array), "type": kind}
        if array.ndim == 2 and array.shape[1] == 3:
            accessor |= {"min": array.min(axis=0).tolist(), "max": array.max(axis=0).tolist()}
        accessors.append(accessor)
        blob += array.tobytes()
    index = {name: i for i, name in enumerate(arrays)}

    def primitive(part: str, attributes: dict[str, int], **extra: object) -> dict:
        targets = [{"POSITION": index[f"{part}_{target}"]} for target in ("jaw", "smile")]
        return {"attributes": attributes, "indices": index[f"{part}_faces"], "targets": targets, **extra}

    document = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "materials": [{"name": "Skin", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.5, 0.4, 1.0]}}],
        "meshes": [
            {
                "name": "Face",
                "extras": {"targetNames": ["jawOpen", "mouthSmile"]},
                "primitives": [
                    primitive(
                        "skin",
                        {"POSITION": 0, "TEXCOORD_0": 1, "NORMAL": 2},
                        material=0,
                    ),
                    primitive("teeth", {"POSITION": index["teeth"], "TEXCOORD_0": index["teeth_uv"]}),
                ],
            }
        ],
        "buffers": [{"byteLength": len(blob), "uri": "data:;base64," + base64.b64encode(blob).decode()}],
        "bufferViews": views,
        "accessors": accessors,
    }
    path.write_text(json_module.dumps(document))
    return arrays


def test_a_gltf_rig_keeps_its_texture_coordinates_normals_and_materials(tmp_path) -> None:
    (tmp_path / "rig").mkdir()
    arrays = dressed_gltf(tmp_path / "rig" / "face.gltf")
    document, _ = pack(tmp_path / "rig" / "face.gltf", tmp_path / "out", "--no-pictures")
    neutral = np.vstack([arrays["skin"], arrays["teeth"]])
    uvs = np.vstack([arrays["skin_uv"], arrays["teeth_uv"]])
    deltas = {
        name: np.vstack([arrays[f"skin_{part}"], arrays[f"teeth_{part}"]])
        for name, part in (("jawOpen", "jaw"), ("mouthSmile", "smile"))
    }
    for index, expression in enumerate(document["expressions"], start=1):
        for name in ("neutral.obj", f"expression_{index:02d}.obj"):
            obj = tmp_path / "out" / name
            assert lines_of(obj, "mtllib") == ["mtllib materials.mtl"]
            assert lines_of(obj, "usemtl") == ["usemtl Skin", "usemtl gltf_default"]
            texture = np.array([line.split()[1:] for line in lines_of(obj, "vt")], dtype=float)
            np.testing.assert_allclose(texture, uvs * [1, -1] + [0, 1], atol=1e-7)  # OBJ's v grows upwards
            assert lines_of(obj, "vn") == ["vn 0.000000 0.000000 1.000000"] * 6
            faces = lines_of(obj, "f")
            assert faces[:4] == [
                "f 1/1/1 2/2/2 5/5/5",
                "f 1/1/1 5/5/5 4/4/4",
                "f 2/2/2 3/3/3 6/6/6",
                "f 2/2/2 6/6/6 5/5/5",
            ]
            assert faces[4:] == ["f 7/7 8/8 9/9"]  # the teeth have texture coordinates, no normals
        posed = neutral + sum(deltas[name] for name in expression["shapes"])
        np.testing.assert_allclose(positions(obj), posed, atol=1e-6)
    written = positions(tmp_path / "out" / "neutral.obj")
    np.testing.assert_array_equal(written.astype(np.float32), neutral)  # the shortest text of each float32
    library = (tmp_path / "out" / "materials.mtl").read_text().splitlines()
    assert library[1:] == ["newmtl Skin", "Kd 0.8 0.5 0.4", "newmtl gltf_default", "Kd 1 1 1"]
    reread = rigs.load(tmp_path / "out" / "neutral.obj", format="obj-folder")
    assert reread.n_vertices == 9 and reread.n_triangles == 5
    pack(
        tmp_path / "rig" / "face.gltf",
        tmp_path / "on",
        "--no-pictures",
        "--target",
        tmp_path / "rig" / "face.gltf",
    )
    on_target = tmp_path / "on" / "on_target"
    assert (on_target / "materials.mtl").read_text() == (tmp_path / "out" / "materials.mtl").read_text()
    assert (on_target / "expression_01.obj").read_text().split("\n", 1)[1] == (
        tmp_path / "out" / "expression_01.obj"
    ).read_text().split("\n", 1)[1]  # the same lines (the target is the template itself), the comment apart


def test_glb_holds_the_expressions_as_morph_targets(tmp_path) -> None:
    pytest.importorskip("pygltflib")
    document, _ = pack("tiny", tmp_path / "out", "--glb", "--no-pictures")
    glb = rigs.load(tmp_path / "out" / "expressions.glb", noise_floor=0.0)
    tiny = rigs.generate("tiny")
    assert tiny.provenance.units == "cm" and glb.provenance.units == "m"  # (glTF's unit: scaled to it)
    count = len(document["expressions"])
    assert glb.names == tuple(f"expression_{i:02d}" for i in range(1, count + 1))
    for delta, expression in zip(glb.deltas, document["expressions"], strict=True):
        expected = tiny.deltas[tiny.indices(expression["shapes"])].sum(axis=0) / 100.0
        assert np.abs(delta - expected).max() < 1e-7
    assert np.abs(glb.neutral - tiny.neutral / 100.0).max() < 1e-7 and glb.n_triangles == tiny.n_triangles


def test_empty_shapes_are_recorded_as_excluded_with_the_reason(tmp_path) -> None:
    tiny = rigs.generate("tiny")
    silent = replace(
        tiny,
        deltas=np.concatenate([tiny.deltas, np.zeros((1, *tiny.neutral.shape))]),
        names=(*tiny.names, "x"),
    )
    document, _ = pack(rigs.save(silent, tmp_path / "silent.npz"), tmp_path / "out", "--no-pictures")
    assert document["excluded"] == [
        {"shape": "x", "reason": "empty: no displacement above the noise floor (sec. 4.1)"}
    ]
    assert document["sequence"]["seed"] == 0 and set(document["params"]) >= {"mu", "max_per_expression"}


@pytest.fixture
def cache(monkeypatch, tmp_path) -> Path:
    monkeypatch.setenv(CACHE_VARIABLE, str(tmp_path / "cache"))
    return tmp_path / "cache"


def test_rigs_list_shows_presets_and_fetched_rigs_with_their_cache(cache) -> None:
    listing = json.loads(invoke("rigs", "list", "--json").output)
    kinds = {row["name"]: (row["kind"], row["cached"]) for row in listing}
    assert kinds["faceunits"] == ("fetched", None) and kinds["tiny"] == ("preset", None)
    assert set(rigs.PRESETS) <= set(kinds)
    result = invoke("pack", "faceunits", "--out", cache.parent / "out")
    assert result.exit_code == 2 and "run `harness rigs fetch faceunits` first" in result.output
    rigs.save(rigs.generate("tiny"), cached_rig_path())  # as if fetched
    listing = json.loads(invoke("rigs", "list", "--json").output)
    assert next(row for row in listing if row["name"] == "faceunits")["cached"] == str(cached_rig_path())
    assert str(cached_rig_path()) in " ".join(invoke("rigs", "list").output.split())
    document, _ = pack("faceunits", cache.parent / "out", "--no-pictures", "--jmax", "1")
    assert document["rig"] == "faceunits" and document["expressions"]
    inside = invoke("pack", "faceunits", "--out", cache / "session")
    assert inside.exit_code == 2 and "apart from the inputs" in inside.output


def conflict_rig(seed: int, n_shapes: int = 7, n_vertices: int = 12) -> rigs.Rig:
    """Shapes moving random vertex sets of a strip (no left/right names, so no pairs)."""
    generator = np.random.default_rng(seed)
    x = np.arange(n_vertices, dtype=float)
    neutral = np.stack([np.repeat(x, 2), np.tile([0.0, 1.0], n_vertices), np.zeros(2 * n_vertices)], axis=1)
    triangles = np.array([[2 * i, 2 * i + 2, 2 * i + 1] for i in range(n_vertices - 1)])
    deltas = np.zeros((n_shapes, len(neutral), 3))
    for k in range(n_shapes):
        moved = generator.choice(len(neutral), size=generator.integers(2, 6), replace=False)
        deltas[k, moved, 2] = 1.0
    return rigs.Rig(neutral, deltas, triangles, tuple(f"shape{k}" for k in range(n_shapes)))


def chromatic_number(rig: rigs.Rig) -> int:
    """Fewest colours of the shapes' conflict graph (shapes sharing a moved vertex), by brute force."""
    import itertools

    moved = np.linalg.norm(rig.deltas, axis=2) > 0
    edges = [(a, b) for a, b in itertools.combinations(range(rig.n_shapes), 2) if (moved[a] & moved[b]).any()]
    for colours in range(1, rig.n_shapes + 1):
        for colouring in itertools.product(range(colours), repeat=rig.n_shapes):
            if all(colouring[a] != colouring[b] for a, b in edges):
                return colours
    raise AssertionError("unreachable: n colours always suffice")


@pytest.mark.parametrize("seed", range(4))
def test_minimum_is_the_chromatic_number_of_the_conflict_graph(seed, tmp_path) -> None:
    rig = conflict_rig(seed)
    path = rigs.save(rig, tmp_path / "rig.npz")
    document, output = pack(path, tmp_path / "out", "--minimum", "--no-symmetry", "--no-pictures")
    fewest = chromatic_number(rig)
    assert len(document["expressions"]) == fewest
    assert document["sequence"]["minimum"] == {
        "count": fewest,
        "lower_bound": fewest,
        "proven": True,
        "time_limit": 60.0,
    }
    assert f"minimum: {fewest} expressions cover every shape, proven (lower bound {fewest})" in output
    assert sorted(name for e in document["expressions"] for name in e["shapes"]) == sorted(rig.names)
    objectives = [e["objective"] for e in document["expressions"]]
    assert all(a >= b - 1e-9 for a, b in zip(objectives, objectives[1:], strict=False))  # importance order


def test_minimum_not_proven_in_time_says_what_was_proven(monkeypatch, tmp_path) -> None:
    monkeypatch.setattr(session._minimum, "SOLVE_IN_WORKER", "tests.harness.minimum_workers:unproven_cover")
    path = rigs.save(conflict_rig(1), tmp_path / "rig.npz")
    document, output = pack(path, tmp_path / "out", "--minimum", "--no-pictures", "--time-limit", "5s")
    count = len(document["expressions"])
    assert document["sequence"]["minimum"]["proven"] is False
    message = (
        f"--minimum not proven within 5s: the fewest expressions is at least {count - 1} and at most "
        f"{count}; the {count} found are written"
    )
    assert message in output and any(message in warning for warning in document["warnings"])


@pytest.mark.parametrize(
    "extra", [["--extra-examples"], ["--jmax", "3"], ["--jmax", "20"], ["--solver", "highs"]], ids=" ".join
)
def test_minimum_refuses_what_it_cannot_honour(tmp_path, extra) -> None:
    """Even a --jmax or --solver given at its default value: --minimum would silently ignore it."""
    result = invoke("pack", "tiny", "--minimum", *extra, "--out", tmp_path / "out")
    assert result.exit_code == 2 and "--minimum covers every shape" in result.output, result.output
    assert not (tmp_path / "out").exists()


def test_the_scan_sheet_renders_in_headless_chromium(faceunits_session, tmp_path) -> None:
    out, document, _ = faceunits_session
    screenshot, pdf = tmp_path / "sheet.png", tmp_path / "sheet.pdf"
    page = out / "session.html"
    run_chromium(page, tmp_path / "profile", "--window-size=1240,1754", f"--screenshot={screenshot}")
    run_chromium(page, tmp_path / "profile", "--no-pdf-header-footer", f"--print-to-pdf={pdf}")
    image = imread(screenshot)[..., :3]
    tinted = np.ptp(image, axis=2) > 0.15  # the pictures' coloured shapes came through
    assert tinted.sum() > 2000
    pages = len(re.findall(rb"/Type\s*/Page\b", pdf.read_bytes()))
    assert pages == 1 + -(-len(document["expressions"]) // 2) + 1  # overview, two takes a page, the TD's


@pytest.mark.parametrize("faces", [False, True])
def test_a_target_whose_vertices_are_in_another_order_is_refused_and_other_proportions_are_not(
    tmp_path, faces
) -> None:
    """A target listing the rig's vertices in another order passes the vertex count and would put every
    expression's offsets on the wrong vertices; a character of other proportions, or 100 times larger, is
    what a target is."""
    rig = rigs.generate("arkit52")
    folder = tmp_path / "rig.npz"
    rigs.save(rig, folder)
    order = np.random.default_rng(0).permutation(rig.n_vertices)

    def target(name: str, vertices: np.ndarray, triangles: np.ndarray) -> Path:
        path = tmp_path / f"{name}.obj"
        lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in vertices.tolist()]
        lines += [f"f {a} {b} {c}" for a, b, c in (triangles + 1).tolist()] if faces else []
        path.write_text("\n".join(lines) + "\n")
        return path

    shuffled = target("shuffled", rig.neutral[order], np.argsort(order)[rig.triangles])
    result = invoke("pack", folder, "--target", shuffled, "--no-pictures", "--out", tmp_path / "refused")
    assert_one_line_error(result, f"{shuffled}: its vertices are not in the order")
    assert not (tmp_path / "refused").exists() or not any((tmp_path / "refused").iterdir())
    parked = rig.neutral.copy()
    parked[:20] += 5.0 * rig.diagonal()  # (hidden parts parked far away: the overall scale holds)
    for name, vertices in [
        ("alien", rigs.warp(rig, "alien").neutral),
        ("giant", rig.neutral * 100.0),
        ("parked", parked),
    ]:
        accepted = target(name, vertices, rig.triangles)
        document, _ = pack(folder, tmp_path / name, "--target", accepted, "--no-pictures", "--jmax", "2")
        assert document["target"] == str(accepted)


def test_what_the_rig_reader_warned_is_on_the_session_sheet(tmp_path, capsys) -> None:
    """A neutral out of line with its shapes is said when the rig is read, and kept in the session's
    warnings (expressions.json and the scan sheet), not only printed."""
    rig = rigs.generate("arkit52")
    offset = np.zeros_like(rig.neutral)
    offset[:] = [0.0, 0.005 * rig.diagonal(), 0.0]
    path = rigs.save(
        rigs.Rig(rig.neutral + offset, rig.deltas - offset, rig.triangles, rig.names), tmp_path / "r.npz"
    )
    with pytest.raises(SystemExit) as ended:  # the command as run: warnings shown as they come, once
        main(["pack", str(path), "--out", str(tmp_path / "out"), "--no-pictures", "--jmax", "2"])
    assert ended.value.code == 0
    output = " ".join(" ".join(capsys.readouterr()).split())
    document = json.loads((tmp_path / "out" / "expressions.json").read_text())
    said = [line for line in document["warnings"] if "the neutral does not line up with the shapes" in line]
    assert len(said) == 1 and said[0].startswith(f"{path}: ") and output.count("does not line up") == 1
    assert "the neutral does not line up" in (tmp_path / "out" / "session.html").read_text()


def test_the_material_libraries_and_texture_maps_of_an_obj_rig_travel_with_the_session(tmp_path) -> None:
    """``mtllib`` lines pass through, so the libraries they name, and the maps those name, are copied at
    the same relative paths (also beside the on-target files that keep the lines); a library outside the
    rig's folder is never read."""
    tiny = rigs.generate("tiny")
    folder = obj_rig_folder(tiny, tmp_path / "face")
    (tmp_path / "secret.mtl").write_text("newmtl secret\n")
    for path in folder.glob("*.obj"):
        path.write_text(path.read_text().replace("mtllib face.mtl", "mtllib mtl/face.mtl ../secret.mtl"))
    (folder / "mtl" / "maps").mkdir(parents=True)
    library = "newmtl skin\nmap_Kd -s 1 1 1 maps/skin.png\nbump maps/skin_n.png # normal\nnewmtl lips\n"
    library += "map_Kd ../lips.png\n"  # (up from the library's folder, still inside the rig's)
    (folder / "lips.png").write_bytes(b"\x89PNG lips")
    (folder / "mtl" / "face.mtl").write_text(library)
    (folder / "mtl" / "maps" / "skin.png").write_bytes(b"\x89PNG colour")
    (folder / "mtl" / "maps" / "skin_n.png").write_bytes(b"\x89PNG normals")
    rigs.save(rigs.Rig(tiny.neutral * 1.1, tiny.deltas[:0], tiny.triangles, ()), tmp_path / "actor.npz")
    actor = tmp_path / "actor"
    (actor / "mtl").mkdir(parents=True)
    (actor / "target.obj").write_text((folder / "neutral.obj").read_text())
    (actor / "mtl" / "face.mtl").write_text("newmtl skin\nKd 0.8 0.6 0.5\n")  # (the actor's own)
    out = tmp_path / "out"
    pack(folder, out, "--target", actor / "target.obj", "--no-pictures", "--jmax", "2")
    assert (out / "mtl" / "face.mtl").read_text() == library
    assert (out / "mtl" / "maps" / "skin.png").read_bytes() == b"\x89PNG colour"
    assert (out / "mtl" / "maps" / "skin_n.png").read_bytes() == b"\x89PNG normals"
    assert (out / "lips.png").read_bytes() == b"\x89PNG lips"
    assert (out / "on_target" / "mtl" / "face.mtl").read_text() == "newmtl skin\nKd 0.8 0.6 0.5\n"
    for place in (out, out / "on_target"):
        assert lines_of(place / "expression_01.obj", "mtllib") == ["mtllib mtl/face.mtl ../secret.mtl"]
    assert not list(out.rglob("secret.mtl"))
    again = tmp_path / "again"  # the template's lines on the target: the template's files beside them
    pack(folder, again, "--target", tmp_path / "actor.npz", "--no-pictures", "--jmax", "2")
    assert (again / "on_target" / "mtl" / "maps" / "skin.png").read_bytes() == b"\x89PNG colour"


def test_a_texture_map_named_with_spaces_travels_and_one_left_behind_is_named(tmp_path) -> None:
    """Blender and Maya write map names with spaces: the words after the statement's options name the file
    (never an option's argument, never a shorter name inside the folder when the whole one leads out); a
    map outside the rig's folder or missing is named in a warning, not dropped unsaid."""
    tiny = rigs.generate("tiny")
    folder = obj_rig_folder(tiny, tmp_path / "face")
    (folder / "tex maps").mkdir()
    (folder / "tex maps" / "skin diff.png").write_bytes(b"\x89PNG spaced")
    (folder / "diff.png").write_bytes(b"\x89PNG decoy")  # (the last word alone names another file)
    (tmp_path / "outside.png").write_bytes(b"\x89PNG outside")
    (folder / "1 skin.png").write_bytes(b"\x89PNG option decoy")
    (folder / "skin.png").write_bytes(b"\x89PNG plain")
    for word_option_decoy in ("r gloss.png", "sphere chrome.png", "on clamp.png"):
        (folder / word_option_decoy).write_bytes(b"\x89PNG word option decoy")
    for name in ("gloss.png", "chrome.png", "clamp.png"):
        (folder / name).write_bytes(b"\x89PNG " + name.encode())
    (folder / "Maps").mkdir()
    (folder / "Maps" / "eye.png").write_bytes(b"\x89PNG windows decoy")
    library = "newmtl skin\nmap_Kd -bm 1.0 tex maps/skin diff.png\nmap_Ks ../outside.png\nbump gone.png\n"
    library += "map_Ka -s 1 1 1 skin.png\nmap_d C:\\Users\\art\\My Maps\\eye.png\n"
    library += "map_Ns -imfchan r gloss.png\nrefl -type sphere chrome.png\nmap_Ke -clamp on -bm 2 clamp.png\n"
    (folder / "face.mtl").write_text(library)
    out = tmp_path / "out"
    with pytest.warns(rigs.RigWarning) as caught:
        pack(folder, out, "--no-pictures", "--jmax", "1")
    said = " ".join(str(warning.message) for warning in caught)
    assert (out / "tex maps" / "skin diff.png").read_bytes() == b"\x89PNG spaced"
    assert not (out / "diff.png").exists()
    assert (out / "skin.png").read_bytes() == b"\x89PNG plain" and not (out / "1 skin.png").exists()
    for name in ("gloss.png", "chrome.png", "clamp.png"):  # (an option's word argument is no part of it)
        assert (out / name).read_bytes() == b"\x89PNG " + name.encode()
    assert not [path.name for path in out.glob("* *.png")]
    assert not (out / "Maps").exists()
    assert not list(out.rglob("outside.png"))
    assert "texture map '../outside.png' (face.mtl:3) is not a readable file inside the rig's folder" in said
    assert "texture map 'gone.png' (face.mtl:4)" in said
