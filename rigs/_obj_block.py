"""One block of OBJ lines read into its positions, face corners as written and groups: in one go with numpy
and Arrow when the block is plain (`plain_block`), else line by line, naming the line at fault
(`line_block`). Both give the same `BlockPart`.

A block is plain when it is ASCII, has spaces and line feeds as its only whitespace, no line continuation,
no indented line and no ``v``, ``vt`` or ``f`` keyword alone or glued to a comment, and its ``v`` lines are
all ``v x y z`` and its ``vt`` lines all of as many values.

Numbers are read strictly: ASCII decimal notation (sign, digits, point, exponent), ``inf`` or ``nan``
(refused as not finite); never ``1_0`` or non-ASCII digits, which Python's ``float`` would take.
"""

from __future__ import annotations

import re
from array import array
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import pyarrow as pa
from pyarrow import csv

from rigs._arrow_lines import _floats, read_vertex_lines
from rigs._obj_faces import Corners, face_corners, plain_corners
from rigs._rig import LARGEST_COORDINATE, RigError

#: A coordinate as written by any exporter: ASCII decimal notation, or inf/nan (refused as not finite).
DECIMAL = re.compile(
    r"[+-]?(?:(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?|inf(?:inity)?|nan)", re.IGNORECASE | re.ASCII
)
#: Group names one ``g`` line may give.
MAX_GROUPS = 256
#: Values a ``v`` line may hold: ``x y z``, ``x y z w`` or ``x y z r g b``.
_VERTEX_VALUES = (3, 4, 6)
#: Characters that send a block to the line-by-line reader: line continuations, and whitespace other than
#: spaces and line ends (``str.split`` splits at it, so a keyword could hide behind it).
_UNPLAIN_CHARACTERS = (b"\\", b"\t", b"\x0b", b"\x0c", b"\x1c", b"\x1d", b"\x1e", b"\x1f")
_LINE_FEED, _SPACE, _HASH = ord("\n"), ord(" "), ord("#")
_FACE_LINE = re.compile(r"^f[ \t]", re.MULTILINE)
_TEXTURE_PARSE = csv.ParseOptions(delimiter=" ", quote_char=False, ignore_empty_lines=False)


@dataclass(frozen=True)
class BlockPart:
    """What one block of lines holds.

    Attributes
    ----------
    vertices : (n, 3) float array
        The positions of its ``v`` lines (checked: finite, within `LARGEST_COORDINATE`).
    textures, normals : int
        Its ``vt`` and ``vn`` lines.
    corners : Corners or None
        The corners of its ``f`` lines as written (None when faces are not read).
    face_rows : int array
        The line number of each ``f`` line.
    defined : (3, F) int array
        The ``v``, ``vt`` and ``vn`` lines of the block before each ``f`` line (for relative indices).
    face_text : bytes
        ``f CORNERS`` lines as written (comments and the spaces around them left out), one per face.
    groups : list of (int, list of str)
        Each ``g`` line's names, after how many of the block's faces.
    first_face : int
        Where the block's first ``f`` line starts in it (-1 without one).
    """

    vertices: np.ndarray
    textures: int
    normals: int
    corners: Corners | None
    face_rows: np.ndarray
    defined: np.ndarray
    face_text: bytes
    groups: list[tuple[int, list[str]]]
    first_face: int

    def face_line(self, face: int) -> str:
        """The text of the block's ``face``-th ``f`` line (for messages)."""
        ends = np.flatnonzero(np.frombuffer(self.face_text, dtype=np.uint8) == ord("\n"))
        start = int(ends[face - 1]) + 1 if face else 0
        return self.face_text[start : ends[face]].decode("utf-8", errors="replace")


def is_plain(block: bytes) -> bool:
    """Whether ``block`` is ASCII with no line continuation and no whitespace but spaces and line feeds."""
    return block.isascii() and not any(character in block for character in _UNPLAIN_CHARACTERS)


@dataclass(frozen=True)
class _Lines:
    """The lines of plain text: where each starts and stops (past its line feed), and which are ``v``,
    ``vt``, ``vn``, ``f`` and possible ``g`` lines (by their first characters)."""

    starts: np.ndarray
    stops: np.ndarray
    vertex: np.ndarray
    texture: np.ndarray
    normal: np.ndarray
    face: np.ndarray
    group: np.ndarray

    @classmethod
    def of(cls, text: bytes) -> _Lines | None:
        """The lines of ``text`` (plain characters), or None when a line is indented or holds a ``v``,
        ``vt`` or ``f`` keyword alone or glued to a comment (the line-by-line reader's to judge)."""
        data = np.frombuffer(text + b"\n\n\n", dtype=np.uint8)
        ends = np.flatnonzero(data[: len(text)] == _LINE_FEED)
        starts = np.concatenate([[0], ends + 1])
        if starts[-1] == len(text):
            starts = starts[:-1]
        stops = np.append(ends + 1, len(text))[: len(starts)]
        first, second, third = data[starts], data[starts + 1], data[starts + 2]
        v, f = first == ord("v"), first == ord("f")
        word_end = (third == _SPACE) | (third == _LINE_FEED) | (third == _HASH)
        texture, normal = v & (second == ord("t")) & word_end, v & (second == ord("n")) & word_end
        alone = ((second == _LINE_FEED) | (second == _HASH)) & (v | f) | texture & (third != _SPACE)
        if (first == _SPACE).any() or alone.any():
            return None
        spaced = second == _SPACE
        return cls(
            starts,
            stops,
            np.flatnonzero(v & spaced),
            np.flatnonzero(texture),
            np.flatnonzero(normal),
            np.flatnonzero(f & spaced),
            np.flatnonzero(first == ord("g")),
        )

    def text_of(self, text: bytes, rows: np.ndarray) -> bytes:
        """The lines ``rows`` (ascending) of ``text``, each ending in a line feed, joined."""
        if not len(rows):
            return b""
        breaks = np.flatnonzero(np.diff(rows) != 1) + 1
        firsts, lasts = rows[np.r_[0, breaks]], rows[np.r_[breaks - 1, len(rows) - 1]]
        starts, stops = self.starts[firsts].tolist(), self.stops[lasts].tolist()
        block = b"".join(text[start:stop] for start, stop in zip(starts, stops, strict=True))
        return block if block.endswith(b"\n") else block + b"\n"


def plain_block(block: bytes, first_line: int, source: str, *, with_faces: bool) -> BlockPart | None:
    """The `BlockPart` of a plain block (`is_plain`) read in one go, or None to leave the block, and
    naming the line at fault, to `line_block`.

    Raises
    ------
    RigError
        For a face or ``g`` line `line_block` would refuse.
    """
    lines = _Lines.of(block)
    if lines is None:
        return None
    vertices = plain_vertex_block(lines.text_of(block, lines.vertex)) if len(lines.vertex) else _NO_VERTICES
    if vertices is None:
        return None
    if (
        with_faces
        and len(lines.texture)
        and _plain_texture_block(lines.text_of(block, lines.texture)) is None
    ):
        return None
    face_block = lines.text_of(block, lines.face)
    regular = not (b"#" in face_block or b"f  " in face_block or b" \n" in face_block)
    face_rows = lines.face + first_line
    corners = None
    if with_faces and len(lines.face):
        corners = plain_corners(face_block)
        if corners is None:
            corners = face_corners(_face_lines(face_block), face_rows.tolist(), source)
    if not regular:
        face_block = "".join(f"f {line}\n" for line in _face_lines(face_block)).encode()
    defined = np.stack(
        [np.searchsorted(rows, lines.face) for rows in (lines.vertex, lines.texture, lines.normal)]
    )
    return BlockPart(
        vertices,
        len(lines.texture),
        len(lines.normal),
        corners,
        face_rows,
        defined,
        face_block,
        _groups(block, lines, first_line, source),
        int(lines.starts[lines.face[0]]) if len(lines.face) else -1,
    )


_NO_VERTICES = np.zeros((0, 3))


def _face_lines(face_block: bytes) -> list[str]:
    """The corners of each ``f`` line of a plain face block, without comments and the spaces around."""
    return [line[2:].split("#", 1)[0].strip() for line in face_block.decode().split("\n")[:-1]]


def _groups(block: bytes, lines: _Lines, first_line: int, source: str) -> list[tuple[int, list[str]]]:
    """Each ``g`` line's names, after how many of the block's faces (as `line_block` records them)."""
    found = []
    for row, start, stop in zip(
        lines.group.tolist(),
        lines.starts[lines.group].tolist(),
        lines.stops[lines.group].tolist(),
        strict=True,
    ):
        words = block[start:stop].decode().split("#", 1)[0].split(None, MAX_GROUPS + 2)
        if words[:1] != ["g"]:
            continue
        if len(words) > MAX_GROUPS + 1:
            raise RigError(f"{source}:{row + first_line}: 'g' line names more than {MAX_GROUPS} groups")
        found.append((int(np.searchsorted(lines.face, row)), words[1:] or ["default"]))
    return found


def plain_vertex_block(block: bytes | str) -> np.ndarray | None:
    """(N, 3) positions of a vertex block of plain ``v x y z`` lines read in one go (`read_vertex_lines`,
    outside the interpreter lock, so that several files are read at once); None for any other line, no
    line, or a non-finite or too large coordinate, left to the line-by-line reader, which names the line."""
    vertices = read_vertex_lines(block) if block else None
    if vertices is None or not (np.abs(vertices) <= LARGEST_COORDINATE).all():  # (False for NaN)
        return None
    return vertices


def _plain_texture_block(block: bytes) -> np.ndarray | None:
    """The values of plain ``vt`` lines of as many values each (1 to 3), read with Arrow; None for
    anything else or a value that is not finite (left to the line-by-line reader, which names the line)."""
    count = block[: block.index(b"\n")].count(b" ")
    if not 1 <= count <= 3:
        return None
    names = ["keyword", *(f"c{index}" for index in range(count))]
    try:
        table = csv.read_csv(
            pa.py_buffer(block),
            read_options=csv.ReadOptions(column_names=names, use_threads=False, block_size=1 << 26),
            parse_options=_TEXTURE_PARSE,
            convert_options=csv.ConvertOptions(
                column_types=dict.fromkeys(names[1:], pa.float64()), null_values=[], strings_can_be_null=False
            ),
        )
    except pa.ArrowInvalid:
        return None
    values = np.column_stack([_floats(table.column(name)) for name in names[1:]])
    return values if np.isfinite(values).all() else None


# -- line by line --------------------------------------------------------------------------------------------
def is_continued(data: bytes | str, end: int) -> bool:
    """Whether the line whose line end is at ``end`` (of bytes or text) continues onto the next: it ends
    with ``\\`` before any blanks (spaces, tabs, CRs; however many). A CR line end just before ``end`` is
    read as a blank, so an empty line after a CR-ended continued one also counts as continued: a cut is
    then only made later."""
    blanks, mark = (b" \t\r", b"\\") if isinstance(data, bytes) else (" \t\r", "\\")
    look = 64
    while True:
        first = max(0, end - look)
        tail = data[first:end].rstrip(blanks)
        if tail or first == 0:
            return tail.endswith(mark)
        look *= 8


def numbered_lines(text: str, first: int = 1) -> Iterator[tuple[int, str]]:
    """Logical lines with the number of their first physical line (from ``first``); ``\\`` at a line end
    continues it."""
    lines = text.split("\n")
    if "\\" not in text:
        yield from enumerate(lines, first)
        return
    pending: list[str] = []
    start = 0
    for number, line in enumerate(lines, first):
        stripped = line.rstrip(" \t")
        if stripped.endswith("\\"):
            start = start if pending else number
            pending.append(stripped[:-1])
        elif pending:
            yield start, " ".join([*pending, line])
            pending = []
        else:
            yield number, line
    if pending:
        yield start, " ".join(pending)


def line_block(
    text: str, first_line: int, source: str, *, with_faces: bool, vertices_before: int
) -> BlockPart:
    """The `BlockPart` of any block of lines, read one logical line at a time (errors name the line;
    ``vertices_before``: the file's vertices before the block, to number them in messages).

    Raises
    ------
    RigError
        ``source:line: problem`` for a vertex line of other than 3, 4 or 6 values or a coordinate that is
        not an ASCII decimal number, not finite or beyond `LARGEST_COORDINATE`; a texture coordinate line
        of other than 1 to 3 values or a value that is not a finite decimal number (with ``with_faces``);
        a malformed face (`rigs._obj_faces.face_corners`); a ``g`` line naming more than 256 groups.
    """
    coordinates = array("d")
    vertex_rows = array("q")
    counts = [0, 0, 0]  # v, vt, vn lines so far
    face_lines: list[str] = []
    face_rows = array("q")
    defined = array("q")
    groups: list[tuple[int, list[str]]] = []
    for number, written in numbered_lines(text, first_line):
        line = written.split("#", 1)[0] if "#" in written else written
        parts = line.split(None, 1)  # (never splits a whole long line: only its keyword off)
        if not parts:
            continue
        keyword = parts[0]
        if keyword == "v":
            coordinates.extend(_vertex_values(parts, line, f"{source}:{number}"))
            vertex_rows.append(number)
            counts[0] += 1
        elif keyword == "vt":
            if with_faces:
                _check_texture(parts, line, f"{source}:{number}")
            counts[1] += 1
        elif keyword == "vn":
            counts[2] += 1
        elif keyword == "f":
            face_lines.append(parts[1].strip() if len(parts) > 1 else "")
            face_rows.append(number)
            defined.extend(counts)
        elif keyword == "g":
            names = line.split(None, MAX_GROUPS + 1)[1:] or ["default"]
            if len(names) > MAX_GROUPS:
                raise RigError(f"{source}:{number}: 'g' line names more than {MAX_GROUPS} groups")
            groups.append((len(face_lines), names))
    vertices = _checked_vertices(coordinates, vertex_rows, vertices_before, source)
    corners = face_corners(face_lines, face_rows, source) if with_faces and face_lines else None
    return BlockPart(
        vertices,
        counts[1],
        counts[2],
        corners,
        np.frombuffer(face_rows, dtype=np.int64),
        np.frombuffer(defined, dtype=np.int64).reshape(-1, 3).T,
        "".join(f"f {line}\n" for line in face_lines).encode("utf-8"),
        groups,
        _first_face(text) if face_lines else -1,
    )


def _first_face(text: str) -> int:
    """The byte offset of the first line of ``text`` (UTF-8) that starts with an ``f`` keyword, and does
    not continue the line before it (``\\`` at its end: it is then part of that line, not a face)."""
    for found in _FACE_LINE.finditer(text):
        start = found.start()
        if start == 0 or not is_continued(text, start - 1):
            return len(text[:start].encode("utf-8", errors="surrogatepass"))
    return 0


def _vertex_values(parts: list[str], line: str, where: str) -> list[float]:
    """``x y z`` of a ``v`` line split off its keyword (``parts``); `RigError` naming ``where``."""
    values = parts[1].split(None, max(_VERTEX_VALUES)) if len(parts) > 1 else []
    if len(values) < 3:
        raise RigError(f"{where}: vertex needs x y z, got {line.strip()[:80]!r}")
    if len(values) not in _VERTEX_VALUES:
        count = f"more than {max(_VERTEX_VALUES)}" if len(values) > max(_VERTEX_VALUES) else str(len(values))
        raise RigError(
            f"{where}: vertex has {count} values, neither x y z [w] nor x y z r g b: {line.strip()[:80]!r}"
        )
    wrong = [value for value in values if not DECIMAL.fullmatch(value)]
    if wrong:
        raise RigError(
            f"{where}: vertex has a non-numeric coordinate: {line.strip()[:80]!r} "
            f"({wrong[0][:40]!r} is not a number in ASCII decimal notation)"
        )
    return [float(value) for value in values[:3]]


def _check_texture(parts: list[str], line: str, where: str) -> None:
    """Refuse a ``vt`` line (split off its keyword: ``parts``) of other than 1 to 3 finite decimal values."""
    values = parts[1].split(None, 3) if len(parts) > 1 else []
    if not 1 <= len(values) <= 3:
        raise RigError(f"{where}: texture coordinate needs u [v [w]], got {line.strip()[:80]!r}")
    if not all(DECIMAL.fullmatch(value) and np.isfinite(float(value)) for value in values):
        raise RigError(
            f"{where}: texture coordinate is not a finite number in ASCII decimal notation: "
            f"{line.strip()[:80]!r}"
        )


def _checked_vertices(coordinates: array, rows: array, before: int, source: str) -> np.ndarray:
    """(n, 3) positions; `RigError` naming the line of a non-finite or too large one (numbered from
    ``before``)."""
    vertices = np.frombuffer(coordinates, dtype=np.float64).reshape(-1, 3).copy()
    finite = np.isfinite(vertices).all(axis=1)
    if not finite.all():
        i = int(np.flatnonzero(~finite)[0])
        raise RigError(
            f"{source}:{rows[i]}: vertex {before + i} has a non-finite coordinate {vertices[i].tolist()}"
        )
    huge = (np.abs(vertices) > LARGEST_COORDINATE).any(axis=1)
    if huge.any():
        i = int(np.flatnonzero(huge)[0])
        raise RigError(
            f"{source}:{rows[i]}: vertex {before + i} has a coordinate beyond {LARGEST_COORDINATE:g} "
            f"{vertices[i].tolist()} (its lengths would overflow)"
        )
    return vertices
