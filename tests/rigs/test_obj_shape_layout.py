"""A blendshape file that repeats its neutral's text around other ``v`` lines is read by those lines alone,
and reads exactly as the line-by-line reader reads it; any other file steps aside to the whole-file reader.

The files here are laid out as DCC exporters write them: a header, ``v``, ``vt`` and ``vn`` sections,
``usemtl``, ``s`` and ``g`` lines, and ``f v/vt/vn`` faces.
"""

from __future__ import annotations

import contextlib
from unittest import mock

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import rigs
from rigs import RigError
from rigs._obj import _Reader, parse_obj
from rigs._obj_layout import NeutralLayout

GRID = np.array([[x, y, 0.1 * x * y] for y in range(4) for x in range(4)], dtype=float)
TRIANGLES = [(a, a + 1, a + 4) for a in range(11) if a % 4 != 3]
HEADER = "# exported from a DCC\nmtllib head.mtl\no Head\n"


def _export(
    vertices: np.ndarray, header: str = HEADER, normal: str = "0 0 1", vertex: str = "v {} {} {}\n"
) -> str:
    """An exporter's OBJ of the grid's triangles with ``vertices`` (each written as ``vertex``)."""
    return "".join(
        [
            header,
            "".join(vertex.format(*(f"{value:.6f}" for value in row)) for row in vertices.tolist()),
            "".join(f"vt {x / 3:.6f} {y / 3:.6f}\n" for x, y, _ in GRID.tolist()),
            "".join(f"vn {normal}\n" for _ in GRID),
            "usemtl skin\ns 1\ng head\n",
            "".join(f"f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}\n" for a, b, c in np.add(TRIANGLES, 1).tolist()),
        ]
    )


NEUTRAL_TEXT = _export(GRID)
NEUTRAL = parse_obj(NEUTRAL_TEXT, "neutral.obj")
MOVED = GRID + np.where(np.arange(len(GRID))[:, None] % 3 == 0, [0.25, -0.5, 1e-6], 0.0)


def _read(text: str, *, fast: bool, neutral=NEUTRAL):
    """Positions and face digest of a blendshape file read against ``neutral``, or the error raised; with
    ``fast=False`` read line by line (the fast paths step aside)."""
    with contextlib.ExitStack() as stack:
        if not fast:
            stack.enter_context(mock.patch("rigs._obj.plain_block", return_value=None))
            stack.enter_context(mock.patch.object(NeutralLayout, "shape_vertices", return_value=None))
        try:
            mesh = parse_obj(text, "shape.obj", with_faces=False, faces_of=neutral)
        except RigError as error:
            return str(error)
    return mesh.vertices.tolist(), mesh.face_digest


def _agree(text: str, neutral=NEUTRAL) -> None:
    assert _read(text, fast=True, neutral=neutral) == _read(text, fast=False, neutral=neutral)


def test_the_neutral_knows_where_its_vertex_lines_run() -> None:
    layout = NEUTRAL.layout
    assert layout is not None and layout.run is not None
    start, stop = layout.run
    assert (
        NEUTRAL_TEXT.encode()[start:stop]
        == "".join(f"v {x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in GRID.tolist()).encode()
    )
    assert NEUTRAL_TEXT.encode()[layout.face_start :].startswith(b"f 1/1/1 2/2/2 5/5/5\n")


@pytest.mark.parametrize(
    "text",
    [
        _export(MOVED),
        _export(MOVED, header="# blendshape jawOpen\nmtllib head.mtl\no Head\n"),  # its own header
        _export(MOVED, header=""),  # no header
        _export(MOVED, normal="0.1 0.2 0.97"),  # its own normals
    ],
    ids=["repeated", "own-header", "no-header", "own-normals"],
)
def test_a_shape_repeating_its_neutral_is_read_by_its_vertex_lines_alone(text) -> None:
    with mock.patch("rigs._obj._Reader.read", side_effect=AssertionError("read whole")):
        mesh = parse_obj(text, "shape.obj", with_faces=False, faces_of=NEUTRAL)
    assert np.array_equal(mesh.vertices, MOVED.round(6))
    assert mesh.face_digest == NEUTRAL.face_digest != b""
    _agree(text)


_SHAPE = _export(MOVED)
_FIRST_VERTEX = _SHAPE.splitlines()[3]  # "v 0.250000 -0.500000 0.000001"


@pytest.mark.parametrize(
    "edit",
    [
        lambda t: t.replace("f 1/1/1 2/2/2 5/5/5", "f 1/1/1 2/2/2 6/5/5"),  # a face section one byte off
        lambda t: t.replace("f 1/1/1 2/2/2 5/5/5", "f 1/1/1 2/2/2 5/5/5 6/6/6"),  # a corner more
        lambda t: t.replace("usemtl skin\n", "usemtl skin\nf 1 2 3\n"),  # a face before the others
        lambda t: t.replace("vn 0 0 1\n", "vn 0 0 1\nv 9 9 9\n", 1),  # a vertex among the normals
        lambda t: t.replace("vn 0 0 1\n", "vn 0 0 1\nv\t9 9 9\n", 1),  # ... hidden behind a tab
        lambda t: t.replace("vt 0.000000", "vt 0.000000 x", 1),  # a malformed texture coordinate
        lambda t: t.replace("o Head\n", "o Head\nv\t1 2 3\n"),  # a vertex in the header
        lambda t: t.replace("o Head\n", "o Head\ng" + " part" * 300 + "\n"),  # a 'g' line of 300 groups
        lambda t: t.replace("o Head\n", "o Head \\\n"),  # the header continued onto the first vertex
        lambda t: t.replace("o Head\n", "o Head\n# \\\n"),  # a comment ending in a backslash
        lambda t: t.replace(_FIRST_VERTEX, _FIRST_VERTEX + " 1.0"),  # a w value
        lambda t: t.replace(_FIRST_VERTEX, _FIRST_VERTEX[:-9] + " zero"),  # not a number
        lambda t: t.replace(_FIRST_VERTEX, _FIRST_VERTEX[:-9] + " nan"),  # not finite
        lambda t: t.replace(_FIRST_VERTEX, _FIRST_VERTEX[:-9] + " 1e300"),  # too large
        lambda t: t.replace(_FIRST_VERTEX, _FIRST_VERTEX.replace(" ", "\t", 1)),  # a tab
        lambda t: t.replace(_FIRST_VERTEX, _FIRST_VERTEX.replace("0.25", "0\u0662")),  # a non-ASCII digit
        lambda t: t.replace(_FIRST_VERTEX + "\n", _FIRST_VERTEX + "\r\n"),  # a carriage return
        lambda t: t.replace(_FIRST_VERTEX + "\n", _FIRST_VERTEX + "\n# moved\n"),  # a comment among them
        lambda t: t.replace(_FIRST_VERTEX + "\n", _FIRST_VERTEX + "\n\n"),  # an empty line among them
        lambda t: t.replace(_FIRST_VERTEX + "\n", ""),  # a vertex fewer
        lambda t: t.replace(_FIRST_VERTEX + "\n", _FIRST_VERTEX + "\n" + _FIRST_VERTEX + "\n"),  # one more
        lambda t: t.replace("\nvt ", "vt ", 1),  # the last vertex line runs into the first 'vt'
        lambda t: t.replace("vn 0 0 1\n", ""),  # no normals
        lambda t: t.replace("v ", "vt ", 1),  # no vertex line before the texture coordinates
        lambda t: t[: t.index("v ")] + t[t.index("vt ") :],  # no vertex at all
    ],
)
def test_unusual_shape_files_read_as_the_line_by_line_reader_reads_them(edit) -> None:
    text = edit(_SHAPE)
    assert text != _SHAPE
    _agree(text)


@pytest.mark.parametrize(
    "neutral_text",
    [
        _export(GRID, vertex="v {} {} {}\nvt 0 0\n"),  # vertex and texture lines interleaved
        _export(GRID, header="# a note \\\n# continued\n"),  # a continued header line
        _export(GRID, vertex="v  {} {} {}\n"),  # two spaces after the keyword
        _export(GRID, vertex="v {} {} {} 1.0\n"),  # a w value
    ],
    ids=["interleaved", "continued", "spaced", "weighted"],
)
def test_shapes_of_a_neutral_without_one_run_of_plain_vertex_lines_read_line_by_line(neutral_text) -> None:
    neutral = parse_obj(neutral_text, "neutral.obj")
    assert neutral.layout is not None
    for text in (neutral_text, _export(MOVED), neutral_text.replace("0.100000", "0.125000")):
        _agree(text, neutral)


_TOKENS = st.sampled_from(
    ["v", "vt", "vn", "f", "g a", "#", " ", "\t", "\n", "\r", "\\", "/", "1", "-2.5", "1e400", "x"]
    + ["v 1 2 3", "f 1/1/1 2/2/2 3/3/3", "vt 0 0", "vn 0 0 1", "# c", "s 1", "usemtl a"]
)


@settings(max_examples=300, deadline=None)
@given(
    st.lists(
        st.tuples(st.integers(0, _SHAPE.count("\n")), st.lists(_TOKENS, max_size=8), st.booleans()),
        max_size=3,
    )
)
def test_any_line_edits_read_as_the_line_by_line_reader_reads_them(edits) -> None:
    """Each edit replaces a line of a shape file by its tokens run together, or adds them as a line."""
    lines = _SHAPE.split("\n")
    for line, tokens, insert in edits:
        if insert:
            lines.insert(line, "".join(tokens))
        else:
            lines[line] = "".join(tokens)
    _agree("\n".join(lines))


@pytest.fixture
def exported(tmp_path):
    """A folder of the neutral and two blendshape files as an exporter writes them."""
    folder = tmp_path / "export"
    folder.mkdir()
    (folder / "neutral.obj").write_text(NEUTRAL_TEXT)
    (folder / "jawOpen.obj").write_text(_export(MOVED))
    (folder / "smile.obj").write_text(_export(GRID + [0.0, 0.0, 0.5]))
    return folder


def test_an_exported_folder_reads_the_shapes_by_their_vertex_lines(exported) -> None:
    read_whole = []
    reading = _Reader.read

    def spy(reader, data) -> None:
        read_whole.append(reader.source)
        reading(reader, data)

    with mock.patch.object(_Reader, "read", spy):
        rig = rigs.load(exported, noise_floor=0)
    assert read_whole == [str(exported / "neutral.obj")]
    assert rig.names == ("jawOpen", "smile")
    assert np.array_equal(rig.deltas[0], MOVED.round(6) - GRID.round(6))
    assert np.array_equal(rig.deltas[1], (GRID + [0.0, 0.0, 0.5]).round(6) - GRID.round(6))


def test_a_shape_whose_faces_differ_by_one_byte_is_read_as_before(exported) -> None:
    """A vertex index one off is refused, naming the face; a normal index one off is other corners as
    written (the face digest differs) but the same connectivity, and the shape is read."""
    shape = exported / "smile.obj"
    text = shape.read_text()
    shape.write_text(text.replace("f 5/5/5 6/6/6 9/9/9", "f 5/5/5 6/6/6 8/9/9"))
    with pytest.raises(RigError) as caught:
        rigs.load(exported)
    assert str(caught.value) == (
        f"{shape}: connectivity differs from the neutral neutral.obj at face 3 ([5, 6, 8] vs [5, 6, 9])"
    )
    shape.write_text(text.replace("f 5/5/5 6/6/6 9/9/9", "f 5/5/5 6/6/6 9/9/8"))
    assert rigs.load(exported).names == ("jawOpen", "smile")


def test_a_bad_vertex_line_of_a_shape_is_named_by_its_file_and_line(exported) -> None:
    shape = exported / "jawOpen.obj"
    lines = shape.read_text().split("\n")
    lines[7] = "v 1.0 2.0 three"
    shape.write_text("\n".join(lines))
    with pytest.raises(RigError) as caught:
        rigs.load(exported)
    assert str(caught.value).startswith(f"{shape}:8: vertex has a non-numeric coordinate: 'v 1.0 2.0 three'")
