"""Wavefront OBJ text: one mesh's positions, polygons and face groups.

A file is read in one of two ways that give the same mesh. A plain file (ASCII, spaces and line feeds as
its only whitespace, no line continuation, no indented line, no ``v`` or ``f`` keyword alone or glued to
a comment) whose ``v`` lines are all ``v x y z`` is read in one go: numpy finds its lines by their first
two characters and Arrow reads the vertex lines (`rigs._arrow_lines`). Any other file is read line by
line, which also names the line at fault in an error.

Numbers are read strictly: ASCII decimal notation (sign, digits, point, exponent), ``inf`` or ``nan``
(refused later as not finite); never ``1_0`` or non-ASCII digits, which Python's ``float`` would take.
"""

from __future__ import annotations

import re
from array import array
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rigs._arrow_lines import read_vertex_lines
from rigs._obj_faces import faces_of_lines, plain_corners
from rigs._rig import LARGEST_COORDINATE, RigError
from rigs._safe import UnreadableFile, read_bytes

_FACE_LINE = re.compile(r"^f[ \t]([^\n]*)", re.MULTILINE)
#: A coordinate as written by any exporter: ASCII decimal notation, or inf/nan (refused as not finite).
DECIMAL = re.compile(
    r"[+-]?(?:(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?|inf(?:inity)?|nan)", re.IGNORECASE | re.ASCII
)
#: Decimal places `decimal_step` takes for rounding: coordinates with fewer are a design grid (integers,
#: halves), not rounded; more than 9 is below any noise floor.
_ROUNDING_DECIMALS = range(3, 10)
#: Coordinates sampled per file by `decimal_step`.
_STEP_SAMPLE = 3000
#: Group names one ``g`` line may give.
_MAX_GROUPS = 256
#: Characters that send a file to the line-by-line reader: line continuations, and whitespace other than
#: spaces and line ends (``str.split`` splits at it, so a keyword could hide behind it).
_UNPLAIN_CHARACTERS = (b"\\", b"\t", b"\x0b", b"\x0c", b"\x1c", b"\x1d", b"\x1e", b"\x1f")
_LINE_FEED, _SPACE, _HASH = ord("\n"), ord(" "), ord("#")


@dataclass(frozen=True, eq=False)
class ObjMesh:
    """Geometry of one OBJ file.

    Attributes
    ----------
    vertices : (N, 3) float array
        One row per ``v`` line, in file order (texture and normal seams do not split vertices).
    faces : tuple of int arrays
        The polygons as 0-based vertex indices, in file order.
    groups : dict str -> int array
        Face indices of each ``g`` group (a face in several groups is listed in each).
    face_lines : tuple of str
        The corners of each ``f`` line as written, for a fast identical-connectivity check.
    face_section : bytes
        The file from its first ``f`` line on (UTF-8, line ends normalised; set by a full read of a file
        whose faces follow all its vertices), so that blendshape files written with the same face section
        are recognised without splitting it.
    """

    vertices: np.ndarray
    faces: tuple[np.ndarray, ...]
    groups: dict[str, np.ndarray] = field(default_factory=dict)
    face_lines: tuple[str, ...] = ()
    face_section: bytes = b""

    def group_vertices(self, name: str) -> np.ndarray:
        """Sorted vertex indices used by the faces of group ``name``."""
        faces = [self.faces[i] for i in self.groups[name]]
        return np.unique(np.concatenate(faces)) if faces else np.zeros(0, dtype=np.int64)


def parse_obj(
    text: str | bytes, source: str, *, with_faces: bool = True, faces_of: ObjMesh | None = None
) -> ObjMesh:
    """Read OBJ text: ``v`` positions and ``f`` polygons; everything else is skipped.

    Accepted: comments (``#`` to end of line), CRLF or CR line ends, ``\\`` line continuations,
    ``v x y z [w]`` and ``v x y z r g b`` (only the first three values are read, so a line of millions of
    values costs no more than its text), scientific notation, face corners
    ``v``, ``v/vt``, ``v/vt/vn`` and ``v//vn``, negative (relative) indices, and the keywords
    ``vt vn vp o g s usemtl mtllib l p`` (only ``g`` is recorded).

    Parameters
    ----------
    text : str or bytes
        The file's content (bytes: UTF-8, undecodable bytes read as replacement characters).
    source : str
        Name used in error messages (the file path).
    with_faces : bool
        When False, faces are not decoded (``faces`` is empty) but ``face_lines`` is still kept.
    faces_of : ObjMesh, optional
        A fully read mesh (the neutral) whose face lines are reused when this file ends with the same
        face section and has no face line before it (``with_faces=False`` only).

    Raises
    ------
    RigError
        ``source:line: problem`` for a malformed vertex (a coordinate that is not an ASCII decimal number)
        or face, an index of 0 or out of range (also past 64 bits), a face with more corners than the
        mesh has vertices, a non-finite coordinate or one beyond `rigs._rig.LARGEST_COORDINATE`, a ``g``
        line naming more than 256 groups, or a file without vertices.
    """
    data = text.encode("utf-8", errors="surrogatepass") if isinstance(text, str) else text
    if b"\r" in data:
        data = data.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
    if data.isascii():
        fast = _plain_mesh(data, source, with_faces=with_faces, faces_of=None if with_faces else faces_of)
        if fast is not None:
            return fast
    return _line_by_line(data.decode("utf-8", errors="replace"), source, with_faces=with_faces)


def read_obj(
    path: str | Path,
    *,
    with_faces: bool = True,
    faces_of: ObjMesh | None = None,
    root: str | Path | None = None,
) -> ObjMesh:
    """Read an OBJ file (see :func:`parse_obj`).

    Parameters
    ----------
    path : path
    with_faces, faces_of
        As for :func:`parse_obj`.
    root : path, optional
        The rig's folder: ``path`` must resolve inside it (see :mod:`rigs._safe`).

    Raises
    ------
    RigError
        When the file is missing or cannot be read (not a regular file, outside ``root``), or is malformed.
    """
    path = Path(path)
    try:
        data = read_bytes(path, root=None if root is None else Path(root))
    except UnreadableFile as error:
        raise RigError(f"{path}: cannot read OBJ file ({error.reason})") from None
    return parse_obj(data, str(path), with_faces=with_faces, faces_of=faces_of)


# -- the plain file in one go --------------------------------------------------------------------------------
def _plain_characters(data: bytes) -> bool:
    """Whether ASCII ``data`` has no line continuation and no whitespace but spaces and line feeds."""
    return not any(character in data for character in _UNPLAIN_CHARACTERS)


@dataclass(frozen=True)
class _Lines:
    """The lines of plain text: where each starts and stops (past its line feed), and which are ``v``, ``f``
    and possible ``g`` lines (by their first two characters)."""

    starts: np.ndarray
    stops: np.ndarray
    vertex: np.ndarray
    face: np.ndarray
    group: np.ndarray

    @classmethod
    def of(cls, text: bytes) -> _Lines | None:
        """The lines of ``text`` (plain characters), or None when a line is indented or holds a ``v`` or
        ``f`` keyword alone or glued to a comment (the line-by-line reader's to judge)."""
        data = np.frombuffer(text + b"\n\n", dtype=np.uint8)
        ends = np.flatnonzero(data[: len(text)] == _LINE_FEED)
        starts = np.concatenate([[0], ends + 1])
        if starts[-1] == len(text):
            starts = starts[:-1]
        stops = np.append(ends + 1, len(text))[: len(starts)]
        first, second = data[starts], data[starts + 1]
        keyword = (first == ord("v")) | (first == ord("f"))
        if (first == _SPACE).any() or (keyword & ((second == _LINE_FEED) | (second == _HASH))).any():
            return None
        spaced = second == _SPACE
        vertex = np.flatnonzero((first == ord("v")) & spaced)
        face = np.flatnonzero((first == ord("f")) & spaced)
        return cls(starts, stops, vertex, face, np.flatnonzero(first == ord("g")))

    def text_of(self, text: bytes, rows: np.ndarray) -> bytes:
        """The lines ``rows`` (ascending) of ``text``, each ending in a line feed, joined."""
        if not len(rows):
            return b""
        breaks = np.flatnonzero(np.diff(rows) != 1) + 1
        firsts, lasts = rows[np.r_[0, breaks]], rows[np.r_[breaks - 1, len(rows) - 1]]
        starts, stops = self.starts[firsts].tolist(), self.stops[lasts].tolist()
        block = b"".join(text[start:stop] for start, stop in zip(starts, stops, strict=True))
        return block if block.endswith(b"\n") else block + b"\n"


def _plain_mesh(text: bytes, source: str, *, with_faces: bool, faces_of: ObjMesh | None) -> ObjMesh | None:
    """The mesh of a plain file read in one go (the module docstring says which), or None to leave the
    file, and naming the line at fault, to the line-by-line reader.

    When the file ends with the face section of ``faces_of`` (the neutral) and has no face line before
    it, only the text before that section is looked at and the neutral's face lines are the file's.

    Raises
    ------
    RigError
        For a face or ``g`` line the line-by-line reader would refuse (see `rigs._obj_faces.faces_of_lines`).
    """
    tail = faces_of.face_section if faces_of is not None else b""
    if tail and text.endswith(tail):
        head = text[: len(text) - len(tail)]  # (the tail is the neutral's, read already)
        lines = _Lines.of(head) if _plain_characters(head) else None
        if lines is not None and not len(lines.face):
            vertices = _plain_vertex_block(lines.text_of(head, lines.vertex))
            return None if vertices is None else ObjMesh(vertices, (), face_lines=faces_of.face_lines)
    if not _plain_characters(text):
        return None
    lines = _Lines.of(text)
    if lines is None:
        return None
    vertices = _plain_vertex_block(lines.text_of(text, lines.vertex))
    if vertices is None:
        return None
    face_block = lines.text_of(text, lines.face)
    face_lines = [line[2:] for line in face_block.decode().split("\n")[:-1]]
    if b"#" in face_block or b"f  " in face_block or b" \n" in face_block:
        face_lines = [line.split("#", 1)[0].strip() for line in face_lines]
    groups = _groups(text, lines, source)
    if not with_faces or not face_lines:
        return ObjMesh(vertices, (), groups, tuple(face_lines))
    defined_before = np.searchsorted(lines.vertex, lines.face)
    corners = plain_corners(face_block)
    faces = faces_of_lines(face_lines, lines.face + 1, defined_before, len(vertices), source, corners)
    vertices_first = defined_before[0] == len(vertices)
    face_section = text[lines.starts[lines.face[0]] :] if vertices_first else b""
    return ObjMesh(vertices, faces, groups, tuple(face_lines), face_section)


def _spans(lines: _Lines, rows: np.ndarray) -> zip:
    """(start, stop) of each line of ``rows``."""
    return zip(lines.starts[rows].tolist(), lines.stops[rows].tolist(), strict=True)


def _groups(text: bytes, lines: _Lines, source: str) -> dict[str, np.ndarray]:
    """The face indices of each ``g`` group (as the line-by-line reader records them)."""
    rows, names = [], []
    for row, (start, stop) in zip(lines.group.tolist(), _spans(lines, lines.group), strict=True):
        words = text[start:stop].decode().split("#", 1)[0].split(None, _MAX_GROUPS + 2)
        if words[:1] != ["g"]:
            continue
        if len(words) > _MAX_GROUPS + 1:
            raise RigError(f"{source}:{row + 1}: 'g' line names more than {_MAX_GROUPS} groups")
        rows.append(row)
        names.append(words[1:] or ["default"])
    if not rows:
        return {}
    owner = np.searchsorted(rows, lines.face, side="right") - 1  # (ascending: faces follow in order)
    bounds = np.searchsorted(owner, np.arange(len(rows) + 1)).tolist()
    found: dict[str, list[np.ndarray]] = {}
    for index, group_names in enumerate(names):
        if bounds[index] < bounds[index + 1]:
            members = np.arange(bounds[index], bounds[index + 1], dtype=np.int64)
            for name in dict.fromkeys(group_names):  # (a name given twice lists each face twice)
                found.setdefault(name, []).append(np.repeat(members, group_names.count(name)))
    return {name: np.concatenate(parts) for name, parts in found.items()}


def _plain_vertex_block(block: bytes | str) -> np.ndarray | None:
    """(N, 3) positions of a vertex block of plain ``v x y z`` lines read in one go (`read_vertex_lines`,
    outside the interpreter lock, so that several files are read at once); None for any other line, no
    line, or a non-finite or too large coordinate, left to the line-by-line reader, which names the line."""
    vertices = read_vertex_lines(block) if block else None
    if vertices is None or not (np.abs(vertices) <= LARGEST_COORDINATE).all():  # (False for NaN)
        return None
    return vertices


# -- line by line --------------------------------------------------------------------------------------------
def numbered_lines(text: str) -> Iterator[tuple[int, str]]:
    """Logical lines with the number of their first physical line; ``\\`` at a line end continues it."""
    lines = text.split("\n")
    if "\\" not in text:
        yield from enumerate(lines, 1)
        return
    pending: list[str] = []
    first = 0
    for number, line in enumerate(lines, 1):
        stripped = line.rstrip(" \t")
        if stripped.endswith("\\"):
            first = first if pending else number
            pending.append(stripped[:-1])
        elif pending:
            yield first, " ".join([*pending, line])
            pending = []
        else:
            yield number, line
    if pending:
        yield first, " ".join(pending)


def _line_by_line(text: str, source: str, *, with_faces: bool) -> ObjMesh:
    """`parse_obj` one logical line at a time (any file; errors name the line)."""
    coordinates = array("d")
    vertex_line_numbers = array("q")
    face_lines: list[str] = []
    face_line_numbers = array("q")
    face_vertex_counts = array("q")
    group_faces: dict[str, list[int]] = {}
    current_groups: list[str] = []
    for number, written in numbered_lines(text):
        line = written.split("#", 1)[0] if "#" in written else written
        parts = line.split(None, 1)  # (never splits a whole long line: only its keyword off)
        if not parts:
            continue
        keyword = parts[0]
        if keyword == "v":
            values = parts[1].split(None, 3)[:3] if len(parts) > 1 else []
            if len(values) < 3:
                raise RigError(f"{source}:{number}: vertex needs x y z, got {line.strip()[:80]!r}")
            wrong = [value for value in values if not DECIMAL.fullmatch(value)]
            if wrong:
                raise RigError(
                    f"{source}:{number}: vertex has a non-numeric coordinate: {line.strip()[:80]!r} "
                    f"({wrong[0][:40]!r} is not a number in ASCII decimal notation)"
                )
            coordinates.extend([float(value) for value in values])
            vertex_line_numbers.append(number)
        elif keyword == "f":
            for name in current_groups:
                group_faces.setdefault(name, []).append(len(face_lines))
            face_lines.append(parts[1].strip() if len(parts) > 1 else "")
            face_line_numbers.append(number)
            face_vertex_counts.append(len(vertex_line_numbers))
        elif keyword == "g":
            current_groups = line.split(None, _MAX_GROUPS + 1)[1:] or ["default"]
            if len(current_groups) > _MAX_GROUPS:
                raise RigError(f"{source}:{number}: 'g' line names more than {_MAX_GROUPS} groups")

    vertices = _vertices(coordinates, vertex_line_numbers, source)
    faces: tuple[np.ndarray, ...] = ()
    if with_faces and face_lines:
        faces = faces_of_lines(face_lines, face_line_numbers, face_vertex_counts, len(vertices), source)
    groups = {name: np.asarray(indices, dtype=np.int64) for name, indices in group_faces.items()}
    vertices_first = bool(face_lines) and face_vertex_counts[0] == len(vertices)
    first_face = _FACE_LINE.search(text) if with_faces and vertices_first else None
    return ObjMesh(
        vertices=vertices,
        faces=faces,
        groups=groups,
        face_lines=tuple(face_lines),
        face_section=text[first_face.start() :].encode() if first_face else b"",
    )


def _vertices(coordinates: array, line_numbers: array, source: str) -> np.ndarray:
    if not line_numbers:
        raise RigError(f"{source}: no vertices ('v' lines)")
    vertices = np.frombuffer(coordinates, dtype=np.float64).reshape(-1, 3).copy()
    finite = np.isfinite(vertices).all(axis=1)
    if not finite.all():
        i = int(np.flatnonzero(~finite)[0])
        raise RigError(
            f"{source}:{line_numbers[i]}: vertex {i} has a non-finite coordinate {vertices[i].tolist()}"
        )
    huge = (np.abs(vertices) > LARGEST_COORDINATE).any(axis=1)
    if huge.any():
        i = int(np.flatnonzero(huge)[0])
        raise RigError(
            f"{source}:{line_numbers[i]}: vertex {i} has a coordinate beyond {LARGEST_COORDINATE:g} "
            f"{vertices[i].tolist()} (its lengths would overflow)"
        )
    return vertices


def decimal_step(vertices: np.ndarray) -> float:
    """The rounding step of coordinates written with a fixed number of decimals, or 0.

    Exporters write OBJ coordinates with a fixed number of decimals (``%.6f`` in Blender and Maya), so a
    displacement computed as a difference of two files is only known to about one step per coordinate.

    Parameters
    ----------
    vertices : array
        Coordinates as read (a sample of up to 3000 values is tested).

    Returns
    -------
    ``10**-d`` for the fewest decimals ``d`` that write every sampled value exactly, when ``d`` is in
    3..9; else 0 (not rounded, or a design grid of integers or halves).
    """
    flat = np.asarray(vertices, dtype=np.float64).ravel()
    flat = flat[:: max(1, flat.size // _STEP_SAMPLE)]
    for decimals in range(_ROUNDING_DECIMALS.stop):
        scaled = flat * 10.0**decimals
        if np.all(np.abs(scaled - np.rint(scaled)) <= 1e-3):
            return 10.0**-decimals if decimals in _ROUNDING_DECIMALS else 0.0
    return 0.0
