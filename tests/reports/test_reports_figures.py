"""Coverage and RMS figures (paper Figs. 9-10) and expression contact sheets."""

from __future__ import annotations

import io
from dataclasses import replace

import numpy as np
import pytest
from matplotlib.figure import Figure
from PIL import Image

import harness
import render
import rigs
from reports import contact_sheet, coverage_figure, png_bytes, rms_figure
from reports._contact import distinct_sequences, draw_expression


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


def test_draw_expression_shows_the_face_from_the_front_in_the_shape_colours(face):
    ax = Figure().add_subplot()
    active = render.active_vertices(face)
    colours = draw_expression(
        ax, face, ["jawOpen", "browUp_L"], active, rigs.frontal_camera(face), size=(200, 260)
    )
    assert colours.tolist() == render.shape_colours([1, 1]).tolist()
    (image,) = ax.get_images()
    pixels = np.asarray(image.get_array())
    assert pixels.shape == (260, 200, 4)
    rows, columns = np.nonzero(pixels[..., 3] > 0)
    assert (
        abs((columns.min() + columns.max()) / 2 - 100) <= 2 and abs((rows.min() + rows.max()) / 2 - 130) <= 2
    )
    assert np.ptp(rows) > np.ptp(columns)  # the dome is taller than wide: seen from the front
    rgb = pixels[..., :3].reshape(-1, 3).astype(float) / 255
    hue = rgb / np.maximum(rgb.max(axis=1, keepdims=True), 1e-9)
    for colour in colours:
        assert np.isclose(hue, colour / colour.max(), atol=0.03).all(axis=1).sum() > 20  # each shape shows


@pytest.mark.filterwarnings("ignore::packing.MissingTargetWarning")
def test_contact_sheet_colours_the_masks_packing_used(face, monkeypatch):
    import packing

    faint = replace(face, deltas=np.concatenate([face.deltas[:-1], face.deltas[-1:] * 1e-5]))
    assert packing.analyse(faint).empty[-1]  # below packing's noise floor (relative to the diagonal)
    seen = []
    original = render.active_vertices
    monkeypatch.setattr(
        render, "active_vertices", lambda rig, mu=0.3: seen.append(original(rig, mu)) or seen[-1]
    )
    contact_sheet(faint, {"cpsat": [[faint.names[-1], "jawOpen"]]}, mu=0.25)
    (masks,) = seen
    assert np.array_equal(masks, packing.analyse(faint, mu=0.25).masks) and not masks[-1].any()


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
