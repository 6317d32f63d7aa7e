"""Numbers are read strictly and folders that could be read two ways are refused, each with one line
naming the file (and the line) and what is wrong."""

from __future__ import annotations

import json

import numpy as np
import pytest

import rigs
from rigs import RigError
from rigs._obj import parse_obj

NEUTRAL = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"


def _folder(path, shapes: dict[str, str], neutral: str = NEUTRAL):
    path.mkdir(parents=True, exist_ok=True)
    (path / "neutral.obj").write_text(neutral, encoding="utf-8")
    for name, text in shapes.items():
        (path / f"{name}.obj").write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize(
    ("coordinate", "shown"),
    [
        ("1_0", "1_0"),
        ("\uff11", "\uff11"),
        ("\u0661.5", "\u0661.5"),
        ("1__0.5", "1__0.5"),
        ("0x1", "0x1"),
        ("\u0131nf", "\u0131nf"),  # (a dotless i: 'inf' to a case-blind Unicode match, not to float())
    ],
)
@pytest.mark.parametrize("fast", [True, False])
def test_a_coordinate_python_would_read_but_an_obj_cannot_hold_is_refused(coordinate, shown, fast) -> None:
    text = NEUTRAL.replace("v 1 0 0", f"v {coordinate} 0 0")
    if not fast:
        text = "# \\\n" + text  # (a continuation sends the file to the line-by-line reader)
    with pytest.raises(RigError, match=r"shape\.obj:\d: vertex has a non-numeric coordinate") as caught:
        parse_obj(text, "shape.obj")
    assert repr(shown) in str(caught.value) and "\n" not in str(caught.value)


def test_a_blendshape_with_an_underscored_number_is_named_in_the_folder(tmp_path) -> None:
    folder = _folder(tmp_path / "rig", {"jawOpen": NEUTRAL.replace("v 0 1 0", "v 0 1_0 0")})
    with pytest.raises(RigError, match=r"jawOpen\.obj:3: vertex has a non-numeric coordinate"):
        rigs.load(folder)


def test_decimal_notations_exporters_write_still_read() -> None:
    text = "v +.5 -0 1e3\nv 1.E-2 -2.5e+1 7.\nv 0 1 INF\n"
    with pytest.raises(RigError, match="non-finite"):
        parse_obj(text, "a.obj")
    mesh = parse_obj(text.replace("INF", "0"), "a.obj")
    assert np.array_equal(mesh.vertices, [[0.5, 0.0, 1000.0], [0.01, -25.0, 7.0], [0.0, 1.0, 0.0]])


def test_names_equal_up_to_case_are_refused_by_name(tmp_path) -> None:
    folder = _folder(tmp_path / "rig", {"JawOpen": NEUTRAL, "jawOpen": NEUTRAL})
    with pytest.raises(RigError, match=r"'JawOpen' and 'jawOpen' differ only in case") as caught:
        rigs.load(folder)
    assert str(folder) in str(caught.value)
    (folder / "rig.json").write_text(json.dumps({"shapes": ["jawOpen", "JAWOPEN"]}))
    with pytest.raises(RigError, match=r"rig\.json: blendshape names 'jawOpen' and 'JAWOPEN' differ"):
        rigs.load(folder)


def test_objs_in_a_subfolder_beside_shapes_are_refused(tmp_path) -> None:
    folder = _folder(tmp_path / "rig", {"jawOpen": NEUTRAL.replace("v 0 1 0", "v 0 1 1")})
    assert rigs.load(folder).names == ("jawOpen",)
    _folder(folder / "old", {"smile": NEUTRAL})
    with pytest.raises(
        RigError, match=r"blendshapes sit beside the neutral neutral\.obj and the subfolder old"
    ):
        rigs.load(folder)
    (folder / "rig.json").write_text(json.dumps({"shapes": ["jawOpen"]}))  # a manifest says which
    assert rigs.load(folder).names == ("jawOpen",)
