"""Coverage and RMS figures (paper Figs. 9-10) and expression contact sheets."""

from __future__ import annotations

import io

import numpy as np
import pytest
from matplotlib.figure import Figure
from PIL import Image

import harness
import rigs
from reports import contact_sheet, coverage_figure, png_bytes, rms_figure
from reports._contact import camera_basis, distinct_sequences, draw_expression, rasterize, shaded_colours


def _lines(ax) -> dict[str, tuple[list[float], list[float]]]:
    return {
        line.get_label(): (np.asarray(line.get_xdata()).tolist(), np.asarray(line.get_ydata()).tolist())
        for line in ax.get_lines()
    }


def test_coverage_figure_plots_covered_shapes_per_solver(make_run, face_rig_file):
    records = harness.read_records(make_run("run"))
    figure = coverage_figure(records, str(face_rig_file))
    (ax,) = figure.axes
    lines = _lines(ax)
    assert lines["greedy"] == ([0, 1, 2, 3], [0, 2, 7, 9])
    assert lines["highs"] == ([0, 1, 2, 3], [0, 3, 6, 9])
    assert lines["non-empty shapes"][1] == [9, 9]
    assert ax.get_xlabel() == "expressions (count)"
    assert ax.get_ylabel() == "shapes covered (count)"


def test_rms_figure_has_a_row_per_learned_transfer_and_a_column_per_part(make_run, face_rig_file):
    records = harness.read_records(
        make_run("run", importance=(True, False), transfers=("ebfr", "dt", "delta"))
    )
    figure = rms_figure(records, str(face_rig_file))
    assert [ax.get_title().split(", ", 2)[-1] for ax in figure.axes] == [
        "ebfr: all shapes",
        "ebfr: covered shapes",
        "ebfr: uncovered shapes",
    ]
    everything, covered, _ = (_lines(ax) for ax in figure.axes)
    # cpsat, highs and naive-pulp-cbc share the optimal sequence: one line each setting, not three.
    assert sorted(everything) == [
        "cpsat = highs = naive-pulp-cbc (identical) (importance off)",
        "cpsat = highs = naive-pulp-cbc (identical) (importance on)",
        "delta (reference)",
        "dt (reference)",
        "greedy (importance off)",
        "greedy (importance on)",
    ]
    j, rms = everything["greedy (importance off)"]
    assert j == [1, 2, 3]
    assert rms == pytest.approx([0.66 / 3, 0.66 / 8, 0.66 / 10])
    assert everything["dt (reference)"][1] == [0.25, 0.25]
    assert covered["greedy (importance off)"][1] == pytest.approx([0.33 / 3, 0.33 / 8, 0.33 / 10])
    assert "dt (reference)" not in covered
    for ax in figure.axes:
        assert ax.get_ylim()[0] == 0.0  # a 0.5% difference looks like one
    assert figure.axes[0].get_ylim()[1] == pytest.approx(1.08 * 0.3)  # the delta reference is the top
    assert figure.axes[0].get_xlabel() == "training expressions J (count)"
    assert "RMS" in figure.axes[0].get_ylabel() and "units" in figure.axes[0].get_ylabel()


def test_rms_figure_of_references_only_plots_them_as_methods(make_run, face_rig_file):
    records = harness.read_records(make_run("run", transfers=("dt",)))
    figure = rms_figure(records, str(face_rig_file))
    assert figure.axes[0].get_title().endswith("dt: all shapes")
    assert list(_lines(figure.axes[0])) == ["cpsat = greedy = highs = naive-pulp-cbc (identical)"]


def test_figures_refuse_a_rig_without_records(make_run):
    records = harness.read_records(make_run("run"))
    with pytest.raises(ValueError, match="no expression records for rig 'male'"):
        coverage_figure(records, "male")
    with pytest.raises(ValueError, match="no successful transfer records for rig 'male'"):
        rms_figure(records, "male")


def test_png_bytes_are_deterministic(make_run, face_rig_file):
    records = harness.read_records(make_run("run"))
    first = png_bytes(rms_figure(records, str(face_rig_file)))
    assert first == png_bytes(rms_figure(records, str(face_rig_file)))
    assert first.startswith(b"\x89PNG") and b"Software" not in first


def test_camera_looks_at_the_front_of_the_face(face):
    right, up, towards_viewer = camera_basis(face)
    assert towards_viewer == pytest.approx([0, 0, 1], abs=1e-9)
    assert up == pytest.approx([0, 1, 0], abs=1e-9)
    assert right == pytest.approx([1, 0, 0], abs=1e-9)


def test_triangles_touching_active_vertices_take_the_shape_colour(face):
    active = np.zeros((face.n_shapes, face.n_vertices), dtype=bool)
    active[face.index("jawOpen"), :3] = True  # only the first vertices are active
    view = face.neutral @ camera_basis(face).T
    triangle_colours, colours = shaded_colours(face, view, face.indices(["browUp_L", "jawOpen"]), active)
    hue = triangle_colours / triangle_colours.max(axis=1, keepdims=True)
    tinted = np.isclose(hue, colours[1] / colours[1].max(), atol=1e-6).all(axis=1)
    assert np.array_equal(
        np.flatnonzero(tinted), np.flatnonzero(np.isin(face.triangles, [0, 1, 2]).any(axis=1))
    )
    assert not np.isclose(hue, colours[0] / colours[0].max(), atol=1e-6).all(axis=1).any()  # no active vertex


def test_rasterize_fills_triangles_without_holes_and_keeps_the_nearest():
    far = [[0.0, 0.0, 0.0], [40.0, 0.0, 0.0], [0.0, 40.0, 0.0]]
    near = [[10.0, 10.0, 1.0], [30.0, 10.0, 1.0], [10.0, 30.0, 1.0]]
    red, blue = [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]
    for corners, colours in (([far, near], [red, blue]), ([near, far], [blue, red])):
        image = rasterize(np.array(corners), np.array(colours), 50, 60)
        covered = image[..., 3] == 1
        assert abs(covered.sum() - 40 * 40 / 2) <= 45  # the far triangle's area, up to its diagonal edge
        assert covered[:40, :40][np.add.outer(np.arange(40), np.arange(40)) < 38].all()  # no hole inside
        assert not covered[45:, :].any() and not covered[:, 45:].any()
        assert (image[12:27, 12, :3] == blue).all()  # inside the near triangle: blue, in either order
        assert (image[2, 2:35, :3] == red).all()


def test_draw_expression_shows_an_image_of_the_face(face):
    ax = Figure().add_subplot()
    draw_expression(
        ax, face, ["jawOpen"], np.zeros((face.n_shapes, face.n_vertices), bool), camera_basis(face)
    )
    (image,) = ax.get_images()
    pixels = image.get_array()
    assert pixels.shape[1] == 320 and pixels.shape[0] > 320  # the face is taller than wide
    assert pixels[..., 3].mean() > 0.9  # the dome fills its bounding box except at the corners


def test_identical_sequences_share_a_row(fabric):
    rows = distinct_sequences(
        {
            "cpsat": fabric["optimal"],
            "greedy": fabric["greedy"],
            "highs": [list(reversed(e)) for e in fabric["optimal"]],
        }
    )
    assert list(rows) == ["cpsat, highs", "greedy"]


def test_contact_sheet_draws_each_expression_with_its_names(face, fabric):
    figure = contact_sheet(
        face, {"cpsat": fabric["optimal"], "greedy": fabric["greedy"]}, expressions=2, title="face"
    )
    texts = [t.get_text() for ax in figure.axes for t in ax.texts]
    assert [name for name in texts if name != "\u25a0"] == [
        *fabric["optimal"][0],
        *fabric["optimal"][1],
        *fabric["greedy"][0],
        *fabric["greedy"][1],
    ]
    assert sum(len(ax.get_images()) for ax in figure.axes) == 4
    image = Image.open(io.BytesIO(png_bytes(figure)))
    assert image.width > 300 and image.height > 300
    assert png_bytes(figure) == png_bytes(
        contact_sheet(
            face, {"cpsat": fabric["optimal"], "greedy": fabric["greedy"]}, expressions=2, title="face"
        )
    )


def test_contact_sheet_rejects_bad_input(face):
    with pytest.raises(ValueError, match="sequences is empty"):
        contact_sheet(face, {})
    with pytest.raises(ValueError, match="expressions must be >= 1, got 0"):
        contact_sheet(face, {"cpsat": [["jawOpen"]]}, expressions=0)
    with pytest.raises(rigs.RigError, match="no blendshape named 'jawOpn'.*jawOpen"):
        contact_sheet(face, {"cpsat": [["jawOpn"]]})
