"""`render.render_mesh` and the session pictures: depth-buffered, fitted, deterministic, coloured by the
masks packing used, the unmoved face rasterised once and the same for it."""

from __future__ import annotations

import io
from dataclasses import replace

import numpy as np
import pytest
from PIL import Image

import packing
import render
import rigs
from render._raster import Backdrop, Frame, Motion, rasterise, vertex_normals
from session._picture_set import SIZE, face_size
from session._pictures import _legend_picture, legend_layout, prepare_scene, session_pictures
from session._words import plain_words

FRONT = np.eye(3)  # rows right, up, towards the viewer: x right, y up, z nearer
RED, BLUE = np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])


def crossing_triangles() -> tuple[np.ndarray, np.ndarray]:
    """Two triangles that pierce each other: red is nearer on the left, blue on the right."""
    vertices = np.array(
        [
            [-1.0, -1.0, 1.0],
            [1.0, -1.0, -1.0],
            [0.0, 1.0, 0.0],  # red: z falls from left to right
            [-1.0, -1.0, -1.0],
            [1.0, -1.0, 1.0],
            [0.0, 1.0, 0.0],  # blue: z rises from left to right
        ]
    )
    return vertices, np.array([[0, 1, 2], [3, 4, 5]])


@pytest.mark.parametrize("order", [[0, 1], [1, 0]])
def test_the_nearest_surface_wins_even_where_triangles_cross(order) -> None:
    vertices, triangles = crossing_triangles()
    colours = np.array([RED, BLUE])
    image = render.render_mesh(vertices, triangles[order], FRONT, colours[order], width=80, height=80)
    rgb, alpha = image[..., :3].astype(int), image[..., 3]
    row = 60  # low in the picture, where the triangles are wide
    covered = np.flatnonzero(alpha[row] == 255)
    left, right = rgb[row, covered[2]], rgb[row, covered[-3]]
    assert left[0] > 3 * left[2] and right[2] > 3 * right[0]  # red on the left, blue on the right


def test_rendering_in_chunks_gives_the_same_image(monkeypatch) -> None:
    from render import _raster

    rig = rigs.generate("tiny")
    camera = rigs.three_quarter_camera(rigs.frontal_camera(rig))
    fills = np.random.default_rng(0).uniform(0.2, 1.0, (rig.n_triangles, 3))
    whole = render.render_mesh(rig.neutral, rig.triangles, camera, fills, width=90, height=110)
    monkeypatch.setattr(_raster, "_CHUNK_SAMPLES", 500)  # many chunks, merged into the buffers
    assert np.array_equal(
        render.render_mesh(rig.neutral, rig.triangles, camera, fills, width=90, height=110), whole
    )


def test_the_mesh_is_fitted_centred_and_antialiased() -> None:
    square = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 1.0, 0.0], [0.0, 1.0, 0.0]]) + 5.0
    image = render.render_mesh(
        square, np.array([[0, 1, 2], [0, 2, 3]]), FRONT, np.ones((2, 3)) * 0.5, width=100, height=100
    )
    alpha = image[..., 3]
    rows, columns = np.nonzero(alpha)
    assert (columns.min(), columns.max()) == (3, 96)  # 3% margin of the larger side, left and right
    assert abs((rows.min() + rows.max()) / 2 - 49.5) <= 0.5  # centred vertically
    assert (alpha[30:70, 10:90] == 255).all()  # solid inside, no crack along the shared diagonal
    assert set(np.unique(alpha)) - {0, 255}  # partly covered pixels on the edges
    assert (image[..., :3][alpha > 0] > 0).all()  # lit, not black


def session(rig: rigs.Rig, groups: list[list[str]]) -> tuple[list[dict], list]:
    """Expressions of ``groups`` of shape names and their legends, as `session._files` makes them."""
    from session._files import _legend

    expressions = [{"shapes": group, "extra_examples": [], "files": {}} for group in groups]
    return expressions, [_legend(expression, ()) for expression in expressions]


def test_session_pictures_are_the_same_bytes_for_the_same_input_on_any_thread_count() -> None:
    rig = rigs.generate("tiny")
    groups = [list(rig.names[:3]), [rig.names[4]], list(rig.names[5:7])]
    expressions, legends = session(rig, groups)
    serial = list(session_pictures(rig, expressions, legends, 0.3, workers=1))
    assert [path for path, _ in serial] == [
        f"pictures/expression_{index:02d}_{key}.png"
        for index in (1, 2, 3)
        for key in ("front", "front_pose", "three_quarter_pose")
    ]
    assert expressions[0]["files"]["front_pose"] == "pictures/expression_01_front_pose.png"
    again, _ = session(rig, groups)
    assert list(session_pictures(rig, again, legends, 0.3, workers=3)) == serial
    for path, png in serial:
        image = Image.open(io.BytesIO(png))
        assert not image.info  # no text chunks: no software tag, no time stamp
        assert image.size == (SIZE if path.endswith("_front.png") else face_size())


def test_a_scene_prepared_ahead_gives_the_same_pictures_and_must_be_of_the_rig_and_threshold() -> None:
    rig = rigs.generate("tiny")
    groups = [list(rig.names[:3]), [rig.names[4]]]
    expressions, legends = session(rig, groups)
    made_here = list(session_pictures(rig, expressions, legends, 0.3))
    again, _ = session(rig, groups)
    assert list(session_pictures(rig, again, legends, 0.3, scene=prepare_scene(rig, 0.3))) == made_here
    for scene in (prepare_scene(rig, 0.5), prepare_scene(rigs.generate("tiny", seed=1), 0.3)):
        with pytest.raises(ValueError, match="prepared for another rig or threshold"):
            list(session_pictures(rig, again, legends, 0.3, scene=scene))


def test_the_coloured_picture_has_its_legend_on_the_right_and_no_caption_above() -> None:
    rig = rigs.generate("tiny")
    expressions, legends = session(rig, [list(rig.names[:3])])
    png = dict(session_pictures(rig, expressions, legends, 0.3))[expressions[0]["files"]["front"]]
    pixels = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)
    face_width = face_size()[0]
    legend = pixels[:, face_width:]
    for _, _, colour, _ in legends[0]:  # every legend swatch is drawn right of the face
        assert (np.abs(legend - np.round(255 * colour)).sum(axis=2) <= 3).sum() >= 25
    face = np.abs(pixels[:, :face_width] - 255).sum(axis=2) > 10
    rows, columns = np.nonzero(face)
    assert abs((columns.min() + columns.max()) / 2 - face_width / 2) <= 2
    assert rows.min() >= 0.03 * SIZE[1] - 1  # the face fills the height less its margin: no title


def test_bare_poses_show_no_shape_colour_and_the_coloured_picture_does() -> None:
    rig = rigs.generate("tiny")
    expressions, legends = session(rig, [list(rig.names[:3])])
    made = dict(session_pictures(rig, expressions, legends, 0.3))
    for key in ("front_pose", "three_quarter_pose", "front"):
        pixels = np.asarray(Image.open(io.BytesIO(made[expressions[0]["files"][key]])).convert("RGB"))
        tinted = np.ptp(pixels[:, : face_size()[0]].astype(int), axis=2) > 40
        assert tinted.any() == (key == "front"), key


def test_a_backdrop_rasters_a_pose_exactly_as_the_whole_pose() -> None:
    rig = rigs.generate("arkit52")
    camera = rigs.three_quarter_camera(rigs.frontal_camera(rig))
    weights = np.random.default_rng(3).uniform(0.0, 1.0, (4, rig.n_shapes)) * (
        np.random.default_rng(4).uniform(size=(4, rig.n_shapes)) < 0.1
    )
    poses = rig.neutral + np.tensordot(weights, rig.deltas, axes=1)
    frame = Frame.fitted(camera, [rig.neutral, *poses], width=90, height=120)
    normals = vertex_normals(rig.neutral, rig.triangles)
    opacity = np.random.default_rng(5).uniform(0.0, 1.0, rig.n_vertices)
    backdrop = Backdrop(rig.neutral, rig.triangles, frame, normals, opacity)
    for pose in poses:
        motion = Motion.of(pose, rig.neutral, rig.triangles, normals)
        assert 0 < motion.changed.sum() < rig.n_triangles  # a part moves, the rest comes from the backdrop
        assert np.array_equal(motion.normals, vertex_normals(pose, rig.triangles))
        fast, whole = backdrop.pose(pose, motion), rasterise(pose, rig.triangles, frame, opacity=opacity)
        assert np.array_equal(fast.nearest, whole.nearest) and np.array_equal(fast.light, whole.light)
        assert np.array_equal(fast.opacity, whole.opacity)


def test_a_backdrop_with_seams_rasters_a_pose_exactly_as_the_whole_pose() -> None:
    """Twin vertices along a seam share a normal: a pose that moves one side of the seam bends the
    normals of the other side's twins too."""
    rig = rigs.generate("tiny")
    seam = np.flatnonzero(rig.triangles[:, 0] % 2 == 0)  # triangles given copies of their corners
    used = np.unique(rig.triangles[seam])
    copies = np.full(rig.n_vertices, -1)
    copies[used] = rig.n_vertices + np.arange(len(used))
    triangles = rig.triangles.copy()
    triangles[seam] = copies[rig.triangles[seam]]
    neutral = np.vstack([rig.neutral, rig.neutral[used]])
    deltas = np.concatenate([rig.deltas, rig.deltas[:, used]], axis=1)
    frame = Frame.fitted(FRONT, [neutral], width=60, height=60)
    twins = render.coincident(neutral)
    normals = vertex_normals(neutral, triangles, twins)
    backdrop = Backdrop(neutral, triangles, frame, normals)
    for k in range(3):
        pose = neutral + deltas[k]
        motion = Motion.of(pose, neutral, triangles, normals, twins)
        assert np.array_equal(motion.normals, vertex_normals(pose, triangles))
        fast, whole = backdrop.pose(pose, motion), rasterise(pose, triangles, frame)
        assert np.array_equal(fast.nearest, whole.nearest) and np.array_equal(fast.light, whole.light)


def test_a_raster_over_a_background_is_its_painted_image_composited() -> None:
    vertices, triangles = crossing_triangles()
    frame = Frame.fitted(FRONT, [vertices], width=40, height=30)
    raster = rasterise(vertices, triangles, frame)
    colours, background = np.array([RED, BLUE]), np.array([0.2, 0.9, 0.4])
    image = raster.paint(colours).astype(float) / 255.0
    alpha = image[..., 3:]
    expected = image[..., :3] * alpha + background * (1.0 - alpha)
    assert np.abs(raster.over(colours, background) / 255.0 - expected).max() <= 1.5 / 255.0
    assert set(np.unique(alpha)) - {0.0, 1.0}  # edges partly covered: the blend is tested


def test_triangles_take_the_shape_most_of_their_corners_are_active_in() -> None:
    triangles = np.array([[0, 1, 2], [1, 2, 3], [4, 5, 0], [4, 5, 6], [0, 1, 4]])
    active = np.zeros((2, 7), dtype=bool)
    active[0, 0] = True
    active[1, [1, 2, 3]] = True
    fills = render.triangle_colours(triangles, active, np.array([RED, BLUE]))
    skin = fills[3]
    assert [fill.tolist() for fill in fills] == [
        BLUE.tolist(),
        BLUE.tolist(),
        RED.tolist(),
        skin.tolist(),
        RED.tolist(),
    ]
    assert skin.tolist() not in (
        RED.tolist(),
        BLUE.tolist(),
    )  # no corner active: skin; a tie: the first shape
    assert np.array_equal(
        render.triangle_colours(triangles, active[:0], np.zeros((0, 3))), np.tile(skin, (5, 1))
    )


def test_shape_colours_never_repeat_within_an_expression() -> None:
    from matplotlib import colormaps

    for groups in ([1] * 8, [2] * 10, [2, 1, 2], [1] * 30):
        colours = render.shape_colours(groups)
        assert len(colours) == sum(groups) and len({tuple(c) for c in colours.round(6)}) == sum(groups)
    tab20 = np.asarray(colormaps["tab20"].colors)
    assert np.allclose(render.shape_colours([2, 1]), tab20[[0, 1, 2]])  # a pair's two tones, then a hue


@pytest.mark.filterwarnings("ignore::packing.MissingTargetWarning")
def test_active_vertices_are_the_masks_packing_uses() -> None:
    rig = rigs.generate("tiny")
    faint = replace(
        rig, deltas=np.concatenate([rig.deltas, rig.deltas[:1] * 1e-5]), names=(*rig.names, "faint")
    )
    for mu in (0.3, 0.5):
        analysis = packing.analyse(faint, mu=mu)
        masks = render.active_vertices(faint, mu)
        assert np.array_equal(masks, analysis.masks)
    assert analysis.empty[-1] and not masks[-1].any()  # packing's noise floor: the faint shape is empty


def test_a_long_legend_shrinks_and_cuts_its_words_to_fit_the_picture() -> None:
    colours = render.shape_colours([1] * 40)
    words = [f"left upper eyelid squeeze and raise number {k}" for k in range(40)]
    face = np.full((SIZE[1], face_size()[0], 3), 255, dtype=np.uint8)
    image = Image.open(io.BytesIO(_legend_picture(face, words, colours, [])))
    pixels = np.asarray(image.convert("RGB")).astype(int)
    legend = pixels[:, face_size()[0] :]
    for colour in np.round(255 * colours).astype(int):  # all forty swatches fit the height
        assert (np.abs(legend - colour).sum(axis=2) <= 3).sum() >= 9
    assert (pixels[:, -2:] == 255).all()  # no word runs off the right edge


def dome(rows: int = 24, columns: int = 24) -> tuple[np.ndarray, np.ndarray]:
    """A smooth cap of a sphere over a grid, seen from the front (+z)."""
    u, v = np.meshgrid(np.linspace(-0.8, 0.8, columns), np.linspace(-0.8, 0.8, rows))
    vertices = np.stack([u.ravel(), v.ravel(), np.sqrt(2.0 - u.ravel() ** 2 - v.ravel() ** 2)], axis=1)
    corner = (np.arange(rows - 1)[:, None] * columns + np.arange(columns - 1)[None, :]).ravel()
    triangles = np.concatenate(
        [np.stack([corner, corner + 1, corner + columns + 1], axis=1)]
        + [np.stack([corner, corner + columns + 1, corner + columns], axis=1)]
    )
    return vertices, triangles


def test_a_seam_of_twin_vertices_shades_as_the_welded_surface() -> None:
    """glTF splits vertices along UV and material seams: each side's normals alone would draw a band
    across the face (as across a forehead in a three-quarter view)."""
    vertices, triangles = dome()
    centres = vertices[triangles].mean(axis=1)
    upper = centres[:, 1] > 0.1  # the seam runs across the dome
    used = np.unique(triangles[upper])
    copies = np.full(len(vertices), -1)
    copies[used] = len(vertices) + np.arange(len(used))
    split_triangles = triangles.copy()
    split_triangles[upper] = copies[triangles[upper]]
    split = np.vstack([vertices, vertices[used]])
    twins = render.coincident(split)
    assert np.array_equal(twins[len(vertices) :], used)
    assert np.array_equal(twins[: len(vertices)], np.arange(len(vertices)))
    assert np.allclose(
        vertex_normals(split, split_triangles)[used], vertex_normals(vertices, triangles)[used]
    )
    camera = rigs.three_quarter_camera(FRONT, 35.0)
    grey = np.full((len(triangles), 3), 0.8)
    whole = render.render_mesh(vertices, triangles, camera, grey, width=120, height=120)
    seamed = render.render_mesh(split, split_triangles, camera, grey, width=120, height=120)
    assert np.abs(whole.astype(int) - seamed.astype(int)).max() <= 1
    welded_fade = render.edge_fade(vertices, triangles, np.zeros(len(vertices)))
    split_fade = render.edge_fade(split, split_triangles, np.zeros(len(split)))
    assert np.array_equal(split_fade, welded_fade[twins])  # nor is a seam a cut the picture fades at


def cropped_dome() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The dome cut with a staircase along its top (whole cells removed, as a crop of a larger mesh
    does), and how far each vertex moves: a blob in the middle."""
    vertices, triangles = dome(30, 30)
    cells = (triangles.min(axis=1) // 30, triangles.min(axis=1) % 30)
    notch = (cells[0] >= 26) & ((cells[1] // 4) % 2 == 0)  # teeth along the top edge
    kept = triangles[~notch]
    motion = np.exp(-20.0 * (vertices[:, 0] ** 2 + vertices[:, 1] ** 2))
    return vertices, kept, motion


def test_a_face_cut_out_of_a_larger_mesh_fades_out_towards_the_cut() -> None:
    vertices, triangles, motion = cropped_dome()
    fade = render.edge_fade(vertices, triangles, motion)
    from render._fade import open_edges

    cut = np.unique(open_edges(triangles, len(vertices)))
    used = np.unique(triangles)
    assert np.all(fade[cut] == 0.0) and fade[motion > 0.5].min() == 1.0  # the moving middle is opaque
    assert 0 < fade[used].mean() < 1
    frame = Frame.fitted(FRONT, [vertices[used]], width=90, height=90)
    plain = rasterise(vertices, triangles, frame).over(0.8, 1.0)
    faded = rasterise(vertices, triangles, frame, opacity=fade).over(0.8, 1.0)
    edge = plain < 250  # the mesh's pixels
    rows = np.flatnonzero(edge.any(axis=1))
    top = slice(rows.min(), rows.min() + 3)  # the teeth of the staircase
    assert plain[top][edge[top]].mean() < 225 and faded[top][edge[top]].mean() > 248  # gone, into white
    centre = slice(40, 50)
    assert np.array_equal(faded[centre, centre], plain[centre, centre])


def test_open_edges_that_move_or_are_small_are_no_cut() -> None:
    vertices, triangles, motion = cropped_dome()
    assert render.edge_fade(vertices, triangles, np.ones(len(vertices))) is None  # every edge moves
    hole = np.flatnonzero(np.linalg.norm(vertices[triangles].mean(axis=1)[:, :2], axis=1) < 0.1)
    closed_ring = np.delete(triangles, hole, axis=0)  # a small still hole (inside of a mouth)
    fade = render.edge_fade(vertices, closed_ring, np.zeros(len(vertices)))
    around = np.linalg.norm(vertices[:, :2], axis=1) < 0.15
    assert fade is not None and fade[around].min() == 1.0  # only the outline is a cut
    box = np.array([[x, y, z] for x in (0.0, 1.0) for y in (0.0, 1.0) for z in (0.0, 1.0)])
    closed = np.array(
        [[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1]]
        + [[2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]]
    )
    assert render.edge_fade(box, closed, np.zeros(8)) is None  # a closed mesh has no cut


@pytest.mark.parametrize("count", [1, 9, 24])
def test_the_longest_plain_words_labels_fit_the_legend_whole(count) -> None:
    """``mouth to the actor's right (again)`` is wider than the legend's column: it wraps, in the space
    the legend has, rather than being cut."""
    names = sorted(rigs.generate("arkit52").names, key=lambda name: -len(plain_words(name)))
    words = [plain_words(name) + " (again)" for name in ["mouthRight", *names][:count]]
    left = face_size()[0]
    _, entries = legend_layout(words, left)
    for (swatch, lines), said in zip(entries, words, strict=True):
        assert " ".join(text for text, _ in lines) == said  # whole: no ellipsis
        for _, (x0, y0, x1, y1) in [*lines, ("", swatch)]:
            assert left <= x0 and x1 < SIZE[0] and 0 <= y0 and y1 < SIZE[1]  # inside the picture
    tops = [box[1] for _, lines in entries for _, box in lines]
    assert tops == sorted(tops)  # lines one below the other
