"""The fast paths of the OBJ reader read exactly what the line-by-line reader reads, or step aside.

A plain block of lines whose vertex lines are all ``v x y z`` is read in one go (numpy finds the lines,
Arrow reads the vertex lines); a blendshape file ending with its neutral's face section reuses the neutral's
face digest, and one that repeats the rest of the neutral's text around its ``v`` lines is read by those
lines alone. Whatever a file holds, the result (positions, face digest, faces, groups, or the error raised)
must be the line-by-line reader's.
"""

from __future__ import annotations

import contextlib
import re
from unittest import mock

import numpy as np
import pytest
from hypothesis import example, given, settings, strategies as st

from rigs import RigError
from rigs._obj import parse_obj
from rigs._obj_block import is_continued, plain_vertex_block
from rigs._obj_faces import INDEX_KINDS, face_corners, plain_corners
from rigs._obj_layout import NeutralLayout
from rigs._obj_surface import parse_surface

GRID = np.array([[x, y, 0.1 * x * y] for y in range(4) for x in range(4)], dtype=float)
TRIANGLES = [(a, a + 1, a + 4) for a in range(11) if a % 4 != 3]


def _text(vertices: np.ndarray, header: str = "# mesh\n") -> str:
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in vertices.tolist()]
    faces = [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in TRIANGLES]
    return header + "\n".join(lines) + "\n" + "\n".join(faces) + "\n"


NEUTRAL_TEXT = _text(GRID)
NEUTRAL = parse_obj(NEUTRAL_TEXT, "neutral.obj")


def _reading(fast: bool, read, kept):
    """``kept`` of what ``read()`` gives, or the error it raises; with ``fast=False`` the fast paths
    (``rigs._obj_block.plain_block``, and a blendshape file's vertex lines read alone) step aside, leaving
    the line-by-line reader."""
    with contextlib.ExitStack() as stack:
        if not fast:
            stack.enter_context(mock.patch("rigs._obj.plain_block", return_value=None))
            stack.enter_context(mock.patch.object(NeutralLayout, "shape_vertices", return_value=None))
        try:
            found = read()
        except RigError as error:
            return str(error)
    return kept(found)


def _read(text: str, *, fast: bool):
    """Positions and face digest of a blendshape file read against the neutral, or the error raised."""
    return _reading(
        fast,
        lambda: parse_obj(text, "shape.obj", with_faces=False, faces_of=NEUTRAL),
        lambda mesh: (mesh.vertices.tolist(), mesh.face_digest),
    )


def _agree(text: str) -> None:
    assert _read(text, fast=True) == _read(text, fast=False)


def test_a_shape_file_reads_its_positions_and_reuses_the_neutral_face_digest() -> None:
    moved = GRID.copy()
    moved[[2, 9]] += [[0.0, 0.5, 0.25], [1e-3, 0.0, -2.0]]
    mesh = parse_obj(_text(moved, "# shape\n"), "shape.obj", with_faces=False, faces_of=NEUTRAL)
    assert np.array_equal(mesh.vertices, moved)
    assert mesh.face_digest == NEUTRAL.face_digest != b""


@pytest.mark.parametrize(
    "edit",
    [
        lambda t: t.replace("v 1.0 0.0 0.0", "v 1.0 0.0 0.0 1.0"),  # a w value
        lambda t: t.replace("v 1.0 0.0 0.0", "v 1.0 0.0 0.0 # moved"),  # a comment
        lambda t: t.replace("v 1.0 0.0 0.0", "v  1.0   0.0 0.0"),  # extra spaces
        lambda t: t.replace("v 1.0 0.0 0.0", "v 1.0 0.0"),  # too few values
        lambda t: t.replace("v 1.0 0.0 0.0", "v 1.0 0.0 nan"),  # not finite
        lambda t: t.replace("v 1.0 0.0 0.0", "v 1.0 0.0 zero"),  # not a number
        lambda t: t.replace("v 1.0 0.0 0.0", "v 1_0 0.0 0.0"),  # a number for float(), not for C
        lambda t: t.replace("v 1.0 0.0 0.0", "v#1.0 0.0 0.0"),  # keyword glued to a comment
        lambda t: t.replace("v 1.0 0.0 0.0", "v\t1.0 0.0 0.0"),  # a tab
        lambda t: t.replace("v 1.0 0.0 0.0", "v\x0c1.0 0.0 0.0"),  # other whitespace
        lambda t: t.replace("v 1.0 0.0 0.0", "v\xa01.0 0.0 0.0"),  # non-ASCII whitespace
        lambda t: t.replace("v 1.0 0.0 0.0", "  v 1.0 0.0 0.0"),  # indented
        lambda t: t.replace("v 1.0 0.0 0.0\n", "v 1.0 0.0 0.0\nv\n"),  # a bare keyword
        lambda t: t.replace("v 1.0 0.0 0.0\n", ""),  # a vertex fewer
        lambda t: t.replace("v 1.0 0.0 0.0\n", "v 1.0 0.0 0.0\nv 1.0 0.0 0.0\n"),  # one more
        lambda t: t.replace("v 1.0 0.0 0.0\n", "v 1.0 0.0 0.0\nf 1 2 3\n"),  # a face before the others
        lambda t: t.replace("f 1 2 5", "f 1 2 6"),  # other connectivity
        lambda t: t.replace("v 1.0 0.0 0.0", "v 1.0 0.0 \\\n 0.0"),  # a continuation
        lambda t: t.replace("\n", "\r\n"),  # CRLF
        lambda t: t + "v 9.0 9.0 9.0\n",  # a vertex after the faces
    ],
)
def test_unusual_shape_files_read_as_the_line_by_line_reader_reads_them(edit) -> None:
    text = edit(_text(GRID + 0.0, "# shape\n"))
    _agree(text)


_TOKENS = st.sampled_from(
    [
        "v",
        "f",
        "vt",
        "g",
        "g a",
        "#",
        " ",
        "  ",
        "\t",
        "\xa0",
        "\n",
        "\r",
        "\\",
        "/",
        "1",
        "-1",
        "-40",
        "-2.5",
    ]
    + [
        "1e3",
        "1e200",
        "1e400",
        "nan",
        "x",
        "1_0",
        "+.5",
        "v 1 2 3",
        "vn 1 2 3",
        "# c",
        "f 1 2 3",
        "f 1/1 2//3 -1",
        "f" + " 1" * 17,
    ]
)


#: Up to three lines of the neutral, each replaced by up to 12 tokens.
_LINE_EDITS = st.lists(
    st.tuples(st.integers(0, NEUTRAL_TEXT.count("\n")), st.lists(_TOKENS, max_size=12)), max_size=3
)


def _edited(edits: list[tuple[int, list[str]]]) -> str:
    """The neutral's text with each edited line replaced by its tokens run together."""
    lines = NEUTRAL_TEXT.split("\n")
    for line, tokens in edits:
        lines[line] = "".join(tokens)
    return "\n".join(lines)


@settings(max_examples=400, deadline=None)
@given(_LINE_EDITS)
def test_any_line_edits_read_as_the_line_by_line_reader_reads_them(edits) -> None:
    _agree(_edited(edits))


def _full_read(text: str, *, fast: bool):
    """Everything a full read gives, or its error."""

    def kept(mesh):
        groups = {name: indices.tolist() for name, indices in mesh.groups.items()}
        faces = [face.tolist() for face in mesh.faces]
        layout = mesh.layout and (mesh.layout.face_start, mesh.layout.run)
        return mesh.vertices.tolist(), faces, groups, mesh.face_digest, layout

    return _reading(fast, lambda: parse_obj(text, "mesh.obj"), kept)


@settings(max_examples=400, deadline=None)
@given(_LINE_EDITS)
def test_a_full_read_in_one_go_is_the_line_by_line_reading(edits) -> None:
    text = _edited(edits)
    assert _full_read(text, fast=True) == _full_read(text, fast=False)


def test_a_surface_keeps_what_a_vertex_line_holds_after_its_coordinates() -> None:
    with_w = NEUTRAL_TEXT.replace("v 1.0 0.0 0.0\n", "v 1.0 0.0 0.0 1.0\n")
    surface = parse_surface(with_w, "mesh.obj")
    assert surface.vertex_tails.count(" 1.0") == 1
    assert parse_surface(NEUTRAL_TEXT, "mesh.obj").vertex_tails == ("",) * len(GRID)


def _corners_line_by_line(lines: list[str]):
    """Face corners read one token at a time (the reading `face_corners` must match), or the error."""
    sizes, columns = [], ([], [], [])
    for number, line in enumerate(lines, 1):
        tokens = line.split()
        if len(tokens) < 3:
            return f"faces.obj:{number}: face needs at least 3 corners, got 'f {line[:80]}'"
        for token in tokens:
            fields = token.split("/")
            if len(fields) > 3 or fields[1:] == [""]:
                return f"faces.obj:{number}: face has a malformed corner: 'f {line[:80]}'"
            for kind, field in enumerate(fields + [""] * (3 - len(fields))):
                if (field or kind == 0) and not re.fullmatch(r"[+-]?[0-9]+", field):
                    return (
                        f"faces.obj:{number}: face has a malformed {INDEX_KINDS[kind]} index: 'f {line[:80]}'"
                    )
                value = int(field) if field else 0
                far = (field and value == 0) or abs(value) > 2**62
                columns[kind].append(-(2**62) if far and value < 0 else 2**62 if far else value)
        sizes.append(len(tokens))
    return sizes, *columns


def _found(read):
    try:
        corners = read()
    except RigError as error:
        return str(error)
    return corners.sizes.tolist(), *(column.tolist() for column in corners.indices)


_CORNERS = st.sampled_from(
    [
        "1",
        "2",
        "-1",
        "12",
        "0",
        "3/4",
        "3/4/5",
        "1//2",
        "/5",
        "1/",
        "1/2/3/4",
        "x",
        "+3",
        "9" * 20,
        "-" + "9" * 19,
    ]
)
_FACE_LINES = st.lists(st.lists(_CORNERS, min_size=1, max_size=5).map(" ".join), min_size=1, max_size=6)


@settings(max_examples=400, deadline=None)
@given(_FACE_LINES)
def test_face_corners_read_as_line_by_line(lines) -> None:
    assert _found(
        lambda: face_corners(lines, range(1, len(lines) + 1), "faces.obj")
    ) == _corners_line_by_line(lines)


@settings(max_examples=400, deadline=None)
@given(_FACE_LINES)
def test_face_corners_read_with_numpy_are_those_read_line_by_line_or_left_to_them(lines) -> None:
    fast = plain_corners("".join(f"f {line}\n" for line in lines).encode())
    if fast is None:
        return
    assert _found(lambda: fast) == _corners_line_by_line(lines)


def test_plain_face_corners_are_read_with_numpy() -> None:
    corners = plain_corners(b"f 1/1/1 2//2 3/3\nf -1 -2 +3 44\n")
    assert corners.sizes.tolist() == [3, 4]
    assert [column.tolist() for column in corners.indices] == [
        [1, 2, 3, -1, -2, 3, 44],
        [1, 0, 3, 0, 0, 0, 0],
        [1, 2, 0, 0, 0, 0, 0],
    ]


_DECIMALS = st.one_of(
    st.floats(allow_nan=False, allow_infinity=False).map(repr),
    st.from_regex(r"[+-]?[0-9]{1,25}(\.[0-9]{0,25})?([eE][+-]?[0-9]{1,3})?", fullmatch=True),
)


@settings(max_examples=300, deadline=None)
@given(
    st.lists(st.tuples(st.integers(0, len(GRID) - 1), st.tuples(_DECIMALS, _DECIMALS, _DECIMALS)), max_size=6)
)
def test_coordinates_in_any_decimal_notation_read_as_the_line_by_line_reader_reads_them(moves) -> None:
    lines = NEUTRAL_TEXT.split("\n")
    for vertex, words in moves:
        lines[1 + vertex] = "v " + " ".join(words)
    _agree("\n".join(lines))


@pytest.mark.parametrize("blanks", [0, 1, 63, 64, 65, 5000])
def test_a_line_is_continued_by_a_backslash_before_any_number_of_blanks(blanks) -> None:
    for line_end in (b"\n", b"\r\n"):
        data = b"v 1 2 3\nvt 1 \\" + b" \t" * blanks + line_end + b"2\n"
        end = data.index(line_end, len(b"v 1 2 3\n"))
        assert is_continued(data, end)
        assert not is_continued(data.replace(b"\\", b"x"), end)
        assert not is_continued(data, data.index(b"\n"))
    assert not is_continued(b"\\\n" + b" " * blanks + b"\n", 1 + 1 + blanks)


def test_a_plain_vertex_block_is_read_in_one_go_and_anything_else_is_left_to_the_line_readers() -> None:
    block = "".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in GRID.tolist())
    assert np.array_equal(plain_vertex_block(block), GRID)
    for unusual in (
        "v 1 2 3 4\n",
        "v 1 2 3 # c\n",
        "vt 1 2 3\n",
        "v 1  2 3\n",
        "v 1 2 nan\n",
        "\n",
        "v 1 2 1e300\n",
    ):
        assert plain_vertex_block(block + unusual) is None, unusual


def test_plain_files_never_reach_the_line_by_line_reader() -> None:
    moved = GRID.copy()
    moved[5] += 0.5
    grouped = (
        "g left right\n".join(NEUTRAL_TEXT.split("f ", 1)[0:1])
        + "g left right\nf "
        + NEUTRAL_TEXT.split("f ", 1)[1]
    )
    with mock.patch("rigs._obj._line_block", side_effect=AssertionError("line by line")):
        neutral = parse_obj(grouped, "neutral.obj")
        shape = parse_obj(_text(moved, "# shape\n"), "shape.obj", with_faces=False, faces_of=NEUTRAL)
    assert list(neutral.groups) == ["left", "right"] and len(neutral.groups["left"]) == len(TRIANGLES)
    assert np.array_equal(shape.vertices, moved) and shape.face_digest == NEUTRAL.face_digest


@settings(max_examples=300, deadline=None)
@given(_LINE_EDITS, st.sampled_from(["\n", "\r\n", "\r"]), st.integers(1, 300))
@example(edits=[(0, ["v", "v", "v", "v", "# c", "\\"])], line_end="\n", block_bytes=15)
@example(edits=[(16, ["v", "v", "\\"])], line_end="\n", block_bytes=1)  # (a face line continuing another)
def test_a_file_read_in_small_blocks_reads_as_in_one(edits, line_end, block_bytes) -> None:
    """Blocks are cut after line ends: groups, relative indices and continued lines run on across them (a
    file with several faults may be refused for another of them: the first block's)."""
    text = ("g part\n" + _edited(edits)).replace("\n", line_end)
    whole = _full_read(text, fast=True)
    with mock.patch("rigs._obj.BLOCK_BYTES", block_bytes):
        for fast in (True, False):
            found = _full_read(text, fast=fast)
            if isinstance(whole, str):
                assert isinstance(found, str) and found.startswith("mesh.obj"), found
            else:
                assert found == whole
