"""Wavefront OBJ meshes: a tolerant reader, polygon triangulation, and rigs as folders of OBJs.

A rig folder holds the neutral mesh (``neutral.obj`` unless told otherwise) and one OBJ per blendshape with
the same vertices and faces, beside it or, as many exporters write them, in one subfolder (``shapes/``);
the blendshape's name is its file stem. The folder may also hold ``rig.json``
(written by :func:`save_obj_folder`) that fixes the shape order and keeps regions and units.
"""

from __future__ import annotations

import contextvars
import json
import math
import os
import re
import warnings
from array import array
from collections import deque
from collections.abc import Iterable, Iterator, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from functools import cached_property, partial
from itertools import compress, islice
from operator import itemgetter
from pathlib import Path

import numpy as np

from rigs._arrow_lines import read_vertex_lines, triangle_lines, vertex_lines
from rigs._rig import LARGEST_COORDINATE, Rig, RigError, RigWarning, vector_lengths
from rigs._safe import UnreadableFile, check_budget, named_path, read_text, regular_file, rig_entries

MANIFEST = "rig.json"
#: Largest ``rig.json`` read (regions of a dense mesh take a few MiB).
MANIFEST_LIMIT = 64 * 2**20
_VERTEX_LINE = re.compile(r"^v[ \t]([^\n]*)", re.MULTILINE)
_FACE_LINE = re.compile(r"^f[ \t]([^\n]*)", re.MULTILINE)
#: What follows the vertex index in a face corner (``/vt/vn``), up to the next whitespace.
_CORNER_REST = re.compile(r"/\S*")
#: Stems (any case) taken for the neutral mesh when the folder has no ``neutral.obj``: exporters and
#: artists also call it the basis (Blender's shape-key basis), base or rest shape.
NEUTRAL_STEMS = ("neutral", "basis", "base", "rest")
#: Decimal places `decimal_step` takes for rounding: coordinates with fewer are a design grid (integers,
#: halves), not rounded; more than 9 is below any noise floor.
_ROUNDING_DECIMALS = range(3, 10)
#: Coordinates sampled per file by `decimal_step`.
_STEP_SAMPLE = 3000
_UNSAFE_NAME = re.compile(r'[\\/:*?"<>|\x00-\x1f]')
#: Group names one ``g`` line may give.
_MAX_GROUPS = 256


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
    face_text : str
        The file's text from its first ``f`` line on (line ends normalised; set by a full read of a file
        whose faces follow all its vertices), so that blendshape files written with the same face section
        are recognised without splitting it.
    vertex_lines : (N,) object array of str
        Each ``v`` line as written (set by a full read), so that the lines of a blendshape file written
        the same way are known to hold the same positions without reading them.
    """

    vertices: np.ndarray
    faces: tuple[np.ndarray, ...]
    groups: dict[str, np.ndarray] = field(default_factory=dict)
    face_lines: tuple[str, ...] = ()
    face_text: str = ""
    vertex_lines: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=object))

    def group_vertices(self, name: str) -> np.ndarray:
        """Sorted vertex indices used by the faces of group ``name``."""
        faces = [self.faces[i] for i in self.groups[name]]
        return np.unique(np.concatenate(faces)) if faces else np.zeros(0, dtype=np.int64)


def _numbered_lines(text: str) -> Iterator[tuple[int, str]]:
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


def _vertices_only(text: str, faces_of: ObjMesh | None = None) -> ObjMesh | None:
    """Fast path for blendshape files: positions and face corner lists without per-line dispatch.

    When the file ends with the face section of ``faces_of`` (the neutral) and has no face line before
    it, its face lines are those of ``faces_of`` and are not split again. A ``v`` line written exactly as
    the neutral's line of the same vertex has the neutral's position (the same text reads the same); only
    the other lines, the vertices the blendshape moves, are read, as the line-by-line reader reads them.

    Returns None when the file is unusual (any whitespace but spaces and line ends, a line continuation,
    an indented line, a ``v`` or ``f`` keyword alone or glued to a comment), has no vertices, or has a
    vertex line that does not read (too few values, a malformed, non-finite or too large number), leaving
    the line-by-line reader to handle it and name the line.
    """
    if not _plain_characters(text):
        return None
    tail = faces_of.face_text if faces_of is not None else ""
    head = text[: len(text) - len(tail)] if tail and text.endswith(tail) else None
    start = _vertex_block_start(head) if head is not None else None
    if start is not None and (vertices := _plain_vertex_block(head[start:])) is not None:
        return ObjMesh(vertices=vertices, faces=(), face_lines=faces_of.face_lines)
    rows = _vertex_block(head[start:]) if start is not None else None
    if rows is not None:
        face_lines = faces_of.face_lines
    else:
        lines, starts, face_lines = _lines_to_read(text, faces_of)
        if not _plain_starts(set(starts)):
            return None
        rows = list(compress(lines, map("v ".__eq__, starts)))
    vertices = _vertex_positions(rows, faces_of) if rows else None
    if vertices is None:
        return None
    return ObjMesh(vertices=vertices, faces=(), face_lines=face_lines)


def _vertex_block_start(head: str) -> int | None:
    """Where the first ``v`` line of ``head`` (a file's text before its face section) starts, when only
    comment lines come before it (as exporters write files); else None."""
    start = 0 if head.startswith("v ") else head.find("\nv ") + 1
    if start == 0 and not head.startswith("v "):
        return None
    comments = head[: start - 1].split("\n") if start else []
    if any(line[:1] != "#" for line in comments):
        return None
    return start


def _vertex_block(block: str) -> list[str]:
    """The lines of a vertex block (`_vertex_block_start` on): they are not looked at one by one:
    `_vertex_positions` takes them for ``v`` lines where they equal the neutral's and checks the others."""
    rows = block.split("\n")
    if rows[-1] == "":
        rows.pop()
    return rows


def _plain_vertex_block(block: str) -> np.ndarray | None:
    """(N, 3) positions of a vertex block of plain ``v x y z`` lines read in one go (`read_vertex_lines`,
    outside the interpreter lock, so that `_read_shapes` reads several files at once); None for any other
    line or a non-finite or too large coordinate, left to the line readers, which name the line."""
    vertices = read_vertex_lines(block)
    if vertices is None or not (np.abs(vertices) <= LARGEST_COORDINATE).all():  # (False for NaN)
        return None
    return vertices


#: Blendshape files read at once by `load_obj_folder`.
_READERS = min(4, os.cpu_count() or 1)

#: Characters that send a file to the line-by-line reader: line continuations, and whitespace other than
#: spaces and line ends (``str.split`` splits at it, so a keyword could hide behind it).
_UNPLAIN_CHARACTERS = ("\\", "\t", "\x0b", "\x0c", "\x1c", "\x1d", "\x1e", "\x1f")
#: Line beginnings that do too (besides indentation): ``v`` or ``f`` alone or glued to a comment.
_UNPLAIN_STARTS = frozenset({"v", "v#", "f", "f#"})
_FIRST_TWO = itemgetter(slice(0, 2))


def _plain_characters(text: str) -> bool:
    """ASCII without `_UNPLAIN_CHARACTERS`."""
    return text.isascii() and not any(character in text for character in _UNPLAIN_CHARACTERS)


def _plain_starts(kinds: set[str]) -> bool:
    """Whether lines beginning with ``kinds`` (their first two characters) are plain: none indented, none
    of `_UNPLAIN_STARTS`."""
    return not kinds & _UNPLAIN_STARTS and not any(kind[:1] == " " for kind in kinds)


def _plain_mesh(text: str, source: str) -> ObjMesh | None:
    """A full read of a plain file without groups (as `_vertices_only` tells plain files) in one go: the
    same mesh the line-by-line reader makes of it, or None to leave the file (and naming the line at
    fault) to that reader.

    Raises
    ------
    RigError
        For a face the line-by-line reader would refuse (see `_faces`).
    """
    if not _plain_characters(text):
        return None
    lines, starts, face_lines = _lines_to_read(text, None)
    kinds = set(starts)
    if not _plain_starts(kinds) or kinds & {"g", "g ", "g#"}:
        return None
    is_vertex = np.fromiter(map("v ".__eq__, starts), dtype=bool, count=len(starts))
    rows = list(compress(lines, is_vertex))
    vertices = _plain_vertex_block("\n".join(rows) + "\n") if rows else None
    if vertices is None:
        vertices = _read_rows(rows) if rows else None
    if vertices is None or not (np.abs(vertices) <= LARGEST_COORDINATE).all():  # (False for NaN)
        return None
    is_face = np.fromiter(map("f ".__eq__, starts), dtype=bool, count=len(starts))
    defined_before = np.cumsum(is_vertex)[is_face]
    faces = ()
    if face_lines:
        numbers = np.flatnonzero(is_face) + 1
        faces = _faces(list(face_lines), numbers, defined_before, len(vertices), source)
    first_face = 0 if text.startswith("f ") else text.find("\nf ") + 1
    return ObjMesh(
        vertices=vertices,
        faces=faces,
        face_lines=face_lines,
        face_text=text[first_face:] if face_lines and defined_before[0] == len(vertices) else "",
        vertex_lines=np.array(rows, dtype=object),
    )


def _lines_to_read(text: str, faces_of: ObjMesh | None) -> tuple[list[str], list[str], tuple[str, ...]]:
    """The lines that may hold vertices with their first two characters, and the face lines: the lines
    before the neutral's (``faces_of``) face section and its face lines when the file ends with that
    section and has no face line before it; else every line and the file's own face lines (corners only,
    comments and trailing blanks dropped)."""
    tail = faces_of.face_text if faces_of is not None else ""
    if tail and text.endswith(tail):
        lines = text[: len(text) - len(tail)].split("\n")
        starts = list(map(_FIRST_TWO, lines))
        if "f " not in starts:
            return lines, starts, faces_of.face_lines
    lines = text.split("\n")
    starts = list(map(_FIRST_TWO, lines))
    face_lines = [line[2:] for line in compress(lines, map("f ".__eq__, starts))]
    joined = "\n" + "\n".join(face_lines) + "\n"
    if "#" in joined or " \n" in joined or "\n " in joined:
        face_lines = [line.split("#", 1)[0].strip() for line in face_lines]
    return lines, starts, tuple(face_lines)


def _vertex_positions(lines: list[str], faces_of: ObjMesh | None) -> np.ndarray | None:
    """(N, 3) positions of ``v`` lines: a line equal to the neutral's (``faces_of``) line of its vertex
    takes the neutral's position (so it is a ``v`` line), the others are read. None when one of those is
    not a plain ``v`` line or does not give three finite coordinates within `LARGEST_COORDINATE`."""
    known = faces_of.vertex_lines if faces_of is not None else ()
    if len(known) == len(lines):
        moved = np.flatnonzero(np.array(lines, dtype=object) != known).tolist()
        vertices = faces_of.vertices.copy()
    else:
        moved, vertices = list(range(len(lines))), np.empty((len(lines), 3))
    changed = [lines[index] for index in moved]
    if any(line[:2] != "v " for line in changed):
        return None
    read = _read_rows(changed)
    if read is None or not (np.abs(read) <= LARGEST_COORDINATE).all():  # (False for NaN)
        return None
    vertices[moved] = read
    return vertices


def _read_rows(lines: list[str]) -> np.ndarray | None:
    """(len(lines), 3) coordinates of ``v`` lines as the line-by-line reader takes them (the first three
    values after the keyword, comments dropped), or None when a line has fewer or a value is not a number.

    Lines of exactly ``v x y z`` are read in one go: every fourth word is then ``v`` and the others are
    the values (a line of another length would leave a ``v`` among them, which does not read as a
    number)."""
    joined = " ".join(lines)
    words = joined.split()
    try:
        if "#" not in joined and len(words) == 4 * len(lines) and words[::4].count("v") == len(lines):
            del words[::4]
            return np.array(list(map(float, words))).reshape(-1, 3)
        fields = [line.split("#", 1)[0].split(None, 4)[1:4] for line in lines]
        if any(len(values) < 3 for values in fields):
            return None
        return np.array([float(value) for values in fields for value in values]).reshape(-1, 3)
    except ValueError:
        return None


def parse_obj(text: str, source: str, *, with_faces: bool = True, faces_of: ObjMesh | None = None) -> ObjMesh:
    """Read OBJ text: ``v`` positions and ``f`` polygons; everything else is skipped.

    Accepted: comments (``#`` to end of line), CRLF or CR line ends, ``\\`` line continuations,
    ``v x y z [w]`` and ``v x y z r g b`` (only the first three values are read, so a line of millions of
    values costs no more than its text), scientific notation, face corners
    ``v``, ``v/vt``, ``v/vt/vn`` and ``v//vn``, negative (relative) indices, and the keywords
    ``vt vn vp o g s usemtl mtllib l p`` (only ``g`` is recorded).

    Parameters
    ----------
    text : str
        The file's content.
    source : str
        Name used in error messages (the file path).
    with_faces : bool
        When False, faces are not decoded (``faces`` is empty) but ``face_lines`` is still kept.
    faces_of : ObjMesh, optional
        A fully read mesh (the neutral) whose face lines are reused when this file ends with the same
        face section (``with_faces=False`` only).

    Raises
    ------
    RigError
        ``source:line: problem`` for a malformed vertex or face, an index of 0 or out of range (also past
        64 bits), a face with more corners than the mesh has vertices, a non-finite coordinate or one
        beyond `rigs._rig.LARGEST_COORDINATE`, a ``g`` line naming more than 256 groups, or a file
        without vertices.
    """
    if "\r" in text:
        text = text.replace("\r\n", "\n").replace("\r", "\n")
    fast = _vertices_only(text, faces_of) if not with_faces else _plain_mesh(text, source)
    if fast is not None:
        return fast
    coordinates = array("d")
    vertex_line_numbers = array("q")
    vertex_lines: list[str] = []
    face_lines: list[str] = []
    face_line_numbers = array("q")
    face_vertex_counts = array("q")
    group_faces: dict[str, list[int]] = {}
    current_groups: list[str] = []
    for number, written in _numbered_lines(text):
        line = written.split("#", 1)[0] if "#" in written else written
        parts = line.split(None, 1)  # (never splits a whole long line: only its keyword off)
        if not parts:
            continue
        keyword = parts[0]
        if keyword == "v":
            vertex_lines.append(written)
            values = parts[1].split(None, 3)[:3] if len(parts) > 1 else []
            if len(values) < 3:
                raise RigError(f"{source}:{number}: vertex needs x y z, got {line.strip()[:80]!r}")
            try:
                coordinates.extend([float(value) for value in values])
            except ValueError:
                raise RigError(
                    f"{source}:{number}: vertex has a non-numeric coordinate: {line.strip()[:80]!r}"
                ) from None
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
        faces = _faces(face_lines, face_line_numbers, face_vertex_counts, len(vertices), source)
    groups = {name: np.asarray(indices, dtype=np.int64) for name, indices in group_faces.items()}
    vertices_first = bool(face_lines) and face_vertex_counts[0] == len(vertices)
    first_face = _FACE_LINE.search(text) if with_faces and vertices_first else None
    return ObjMesh(
        vertices=vertices,
        faces=faces,
        groups=groups,
        face_lines=tuple(face_lines),
        face_text=text[first_face.start() :] if first_face else "",
        vertex_lines=np.array(vertex_lines if with_faces else [], dtype=object),
    )


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
        text = read_text(path, root=None if root is None else Path(root))
    except UnreadableFile as error:
        raise RigError(f"{path}: cannot read OBJ file ({error.reason})") from None
    return parse_obj(text, str(path), with_faces=with_faces, faces_of=faces_of)


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


def _faces(
    lines: list[str], line_numbers: Sequence[int], vertex_counts: Sequence[int], n_vertices: int, source: str
) -> tuple[np.ndarray, ...]:
    """0-based polygons of face lines; ``vertex_counts`` are the vertices defined before each line (for
    negative indices). Raises `RigError` for the first line at fault."""
    counts, flat = _face_corners(lines, line_numbers, n_vertices, source)
    if counts.size and counts.max() > n_vertices:  # a polygon repeats a vertex (and would be costly)
        i = int(np.argmax(counts))
        raise RigError(
            f"{source}:{line_numbers[i]}: face has {counts[i]} corners, more than the mesh's "
            f"{n_vertices} vertices"
        )
    face_of_corner = np.repeat(np.arange(len(counts)), counts)
    defined_before = np.asarray(vertex_counts, dtype=np.int64)[face_of_corner]
    flat = np.where(flat < 0, flat + defined_before, flat - 1)
    bad_corner = (flat < 0) | (flat >= n_vertices)
    if bad_corner.any():
        i = int(face_of_corner[np.flatnonzero(bad_corner)[0]])
        raise RigError(
            f"{source}:{line_numbers[i]}: face indexes a vertex outside 1..{n_vertices} "
            f"(or before any vertex is defined): 'f {lines[i][:80]}'"
        )
    ends = np.cumsum(counts).tolist()
    return tuple(flat[start:end] for start, end in zip([0, *ends[:-1]], ends, strict=True))


def _face_corners(
    lines: list[str], line_numbers: Sequence[int], n_vertices: int, source: str
) -> tuple[np.ndarray, np.ndarray]:
    """Corner counts of face lines and their vertex indices as written (1-based, or negative).

    All lines are split and converted in one go; when that fails, line by line, to name the first line at
    fault.

    Raises
    ------
    RigError
        For a face of fewer than 3 corners, or a vertex index that is not an integer or is past 64 bits.
    """
    counts = np.fromiter(map(len, map(str.split, lines)), dtype=np.int64, count=len(lines))
    joined = " ".join(lines)
    words = (_CORNER_REST.sub("", joined) if "/" in joined else joined).split()
    if len(words) == counts.sum() and counts.min() >= 3:
        try:
            return counts, np.fromiter(map(int, words), dtype=np.int64, count=len(words))
        except (ValueError, OverflowError):
            pass
    corners = array("q")
    for i, line in enumerate(lines):
        tokens = line.split()
        if len(tokens) < 3:
            raise RigError(f"{source}:{line_numbers[i]}: face needs at least 3 corners, got 'f {line[:80]}'")
        try:
            corners.extend([int(token.partition("/")[0]) for token in tokens])
        except ValueError:
            raise RigError(
                f"{source}:{line_numbers[i]}: face has a malformed vertex index: 'f {line[:80]}'"
            ) from None
        except OverflowError:  # an index past 64 bits
            raise RigError(
                f"{source}:{line_numbers[i]}: face indexes a vertex outside 1..{n_vertices}: 'f {line[:80]}'"
            ) from None
    return counts, np.frombuffer(corners, dtype=np.int64)


# -- triangulation -----------------------------------------------------------------------------------------
def triangulate(faces: Sequence[np.ndarray], vertices: np.ndarray) -> np.ndarray:
    """Triangles of polygons, in face order.

    Triangles pass through; a quad is split along its 0-2 diagonal unless the two halves face opposite
    ways (a concave quad), then along 1-3; a convex n-gon is fanned from its first corner, a concave one
    is ear-clipped in the plane of its Newell normal.

    Parameters
    ----------
    faces : sequence of int arrays
        Polygons as vertex indices.
    vertices : (N, 3) float array
        Positions used for the convexity tests.

    Returns
    -------
    (T, 3) int64 array; ``T = sum(len(face) - 2)``.

    Notes
    -----
    Vectorised per polygon size; only concave n-gons (5+ corners) are clipped one by one (see
    `_ear_clip`, expected O(n log n) each).
    """
    if len(faces) == 0:
        return np.zeros((0, 3), dtype=np.int64)
    sizes = np.fromiter((len(face) for face in faces), dtype=np.int64, count=len(faces))
    flat = np.concatenate(faces).astype(np.int64)
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    pieces: list[np.ndarray] = []
    owners: list[np.ndarray] = []
    for size in np.unique(sizes):
        members = np.flatnonzero(sizes == size)
        polygons = flat[starts[members][:, None] + np.arange(size)]
        if size == 3:
            triangles = polygons[:, None, :]
        elif size == 4:
            triangles = _split_quads(polygons, vertices)
        else:
            triangles = _split_ngons(polygons, vertices)
        pieces.append(triangles.reshape(-1, 3))
        owners.append(np.repeat(members, size - 2))
    order = np.argsort(np.concatenate(owners), kind="stable")
    return np.concatenate(pieces)[order]


def _split_quads(quads: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    a, b, c, d = (vertices[quads[:, i]] for i in range(4))
    facing = np.einsum("ij,ij->i", np.cross(b - a, c - a), np.cross(c - a, d - a))
    first = np.stack([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]], axis=1)
    second = np.stack([quads[:, [0, 1, 3]], quads[:, [1, 2, 3]]], axis=1)
    return np.where((facing < 0)[:, None, None], second, first)


def _split_ngons(polygons: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    size = polygons.shape[1]
    points = vertices[polygons]
    normal = np.cross(points, np.roll(points, -1, axis=1)).sum(axis=1)
    turns = np.cross(points - np.roll(points, 1, axis=1), np.roll(points, -1, axis=1) - points)
    scale = np.linalg.norm(normal, axis=1, keepdims=True) ** 2 + np.finfo(float).tiny
    convex = (np.einsum("fij,fj->fi", turns, normal) >= -1e-12 * scale).all(axis=1)
    fan = np.arange(1, size - 1)
    triangles = np.stack(
        [np.repeat(polygons[:, :1], size - 2, axis=1), polygons[:, fan], polygons[:, fan + 1]], axis=2
    )
    for i in np.flatnonzero(~convex):
        triangles[i] = polygons[i][_ear_clip(points[i], normal[i])]
    return triangles


def _ear_clip(points: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """Corner triples of an ear-clipped simple polygon (corners counter-clockwise about ``normal``).

    The clipper works in rounds over the corners that may be ears, in corner order from corner 0: an ear
    (a strictly convex corner whose triangle holds no other corner, boundary included) is clipped, and
    its two neighbours wait for the next round. So one round clips ears that are not adjacent, and the
    triangles stay local (a convex polygon is halved round by round instead of fanned from one corner).
    When a round clips nothing (a self-intersecting polygon), one corner is clipped anyway.

    Notes
    -----
    Only corners that are not strictly convex can lie in an ear's triangle (Meisters 1975), so only those
    are tested, found through a KD-tree of their positions (`_Reflex`). A corner's status changes only
    when a neighbour is clipped or the reflex corner that blocked it (its witness) becomes convex or is
    clipped; exactly those corners are tested again, so reflex corners are never walked over. Expected
    O(n log n) for the polygons of real meshes: 8,000-corner stars, combs and spirals take a fraction of
    a second, where re-scanning every corner after each clip took seconds.
    """
    axis = int(np.argmax(np.abs(normal)))
    plane = np.delete(points, axis, axis=1)
    if (normal[axis] < 0) != (axis == 1):
        plane = plane[:, ::-1]
    n = len(plane)
    before, after = [n - 1, *range(n - 1)], [*range(1, n), 0]
    reflex = _Reflex(plane, _cross2(plane - plane[before], plane[after] - plane) <= 0)
    waiting: dict[int, list[int]] = {}  # witness -> the corners it blocks
    removed = [False] * n
    triangles: list[tuple[int, int, int]] = []
    later: list[int] = []

    def retire(corner: int) -> None:
        if reflex.alive[corner]:
            reflex.retire(corner)
            later.extend(waiting.pop(corner, ()))

    def clip(corner: int) -> None:
        previous, following = before[corner], after[corner]
        triangles.append((previous, corner, following))
        after[previous], before[following] = following, previous
        removed[corner] = True
        retire(corner)
        for neighbour in (previous, following):
            if not reflex.reflex_at(before[neighbour], neighbour, after[neighbour]):
                retire(neighbour)
        later.extend((previous, following))

    current = np.flatnonzero(~reflex.alive).tolist()
    lowest = 0
    while len(triangles) < n - 3:
        later.clear()
        touched: set[int] = set()
        for corner in current:
            if len(triangles) == n - 3:
                break
            if removed[corner] or corner in touched:
                continue
            witness = reflex.blocker(before[corner], corner, after[corner])
            if witness is None:
                touched.update((before[corner], after[corner]))
                clip(corner)
            elif witness >= 0:
                waiting.setdefault(witness, []).append(corner)
        if not later and len(triangles) < n - 3:  # a round without an ear
            while removed[lowest]:
                lowest += 1
            clip(after[lowest])
        current = sorted({corner for corner in later if not removed[corner]})
    while removed[lowest]:
        lowest += 1
    triangles.append((before[lowest], lowest, after[lowest]))
    return np.asarray(triangles, dtype=np.int64)


class _Reflex:
    """The corners of a polygon that are not strictly convex, with a KD-tree to find those in a triangle."""

    #: Below this many reflex corners a direct test is faster than the tree.
    DIRECT = 32

    def __init__(self, plane: np.ndarray, reflex: np.ndarray) -> None:
        self.plane = plane
        self.points = plane.tolist()
        self.alive = reflex.copy()
        self._index(np.flatnonzero(reflex))

    def _index(self, indices: np.ndarray) -> None:
        from scipy.spatial import cKDTree  # (only concave n-gons need it)

        self.indices = indices
        self.tree = cKDTree(self.plane[indices]) if len(indices) > self.DIRECT else None
        self.count = len(indices)

    def reflex_at(self, before: int, corner: int, after: int) -> bool:
        (ax, ay), (bx, by), (cx, cy) = self.points[before], self.points[corner], self.points[after]
        return (bx - ax) * (cy - by) - (by - ay) * (cx - bx) <= 0

    def retire(self, corner: int) -> None:
        """``corner`` was clipped or became convex; the tree is rebuilt when half its corners are retired."""
        self.alive[corner] = False
        self.count -= 1
        if 2 * self.count < len(self.indices):
            self._index(self.indices[self.alive[self.indices]])

    def blocker(self, before: int, corner: int, after: int) -> int | None:
        """None when ``corner`` is an ear; -1 when it is not strictly convex; else a reflex corner inside
        its triangle (boundary included)."""
        if self.reflex_at(before, corner, after):
            return -1
        if self.count == 0:
            return None
        (ax, ay), (bx, by), (cx, cy) = self.points[before], self.points[corner], self.points[after]
        if self.tree is None:
            candidates = self.indices
        else:
            low_x, high_x, low_y, high_y = min(ax, bx, cx), max(ax, bx, cx), min(ay, by, cy), max(ay, by, cy)
            radius = 0.5 * math.hypot(high_x - low_x, high_y - low_y) * (1 + 1e-9) + 1e-300
            found = self.tree.query_ball_point((0.5 * (low_x + high_x), 0.5 * (low_y + high_y)), radius)
            candidates = self.indices[found]
        candidates = candidates[
            self.alive[candidates] & (candidates != before) & (candidates != corner) & (candidates != after)
        ]
        if not candidates.size:
            return None
        px, py = self.plane[candidates, 0], self.plane[candidates, 1]
        inside = (
            ((bx - ax) * (py - ay) - (by - ay) * (px - ax) >= 0)
            & ((cx - bx) * (py - by) - (cy - by) * (px - bx) >= 0)
            & ((ax - cx) * (py - cy) - (ay - cy) * (px - cx) >= 0)
        )
        hits = np.flatnonzero(inside)
        return int(candidates[hits[0]]) if hits.size else None


def _cross2(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def faces_are_triangles(faces: Sequence[np.ndarray]) -> bool:
    """True when every polygon has three corners (the triangles are then the faces)."""
    return all(len(face) == 3 for face in faces)


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


# -- rig folders -------------------------------------------------------------------------------------------
def load_obj_folder(folder: str | Path, *, neutral: str | Path | None = None) -> Rig:
    """A rig from a folder of OBJ files: the neutral plus one OBJ per blendshape (absolute positions).

    Parameters
    ----------
    folder : path
        The folder. Without ``rig.json``, every ``*.obj`` other than the neutral is a blendshape, named by
        its file stem, in sorted order; when the neutral is the only OBJ there, the OBJs of the one
        subfolder that holds any are. With ``rig.json`` (see :func:`save_obj_folder`), its ``shapes`` list
        gives the order and its ``regions`` and ``units`` are kept.
    neutral : str or path, optional
        File name (in the folder) or path of the neutral mesh; default ``neutral.obj``, else the one file
        whose stem is, in any case, one of `NEUTRAL_STEMS` (``Neutral.obj``, ``Basis.obj``, ...).

    Returns
    -------
    Rig with ``deltas[k] = shape_k - neutral`` (Carrigan et al. 2020, sec. 3), the polygons kept in
    ``faces`` when any is not a triangle, and ``meta["source"]``, ``meta["format"] = "obj-folder"``,
    ``meta["units"]`` from ``rig.json`` or ``"unknown"`` (OBJ does not say), and
    ``meta["decimal_step"]``, the coarsest rounding step of the files' coordinates (`decimal_step`; 0
    when they are not written with a fixed number of decimals), which the noise floor respects.

    Raises
    ------
    RigError
        One line naming the file and the problem: missing folder or neutral, no blendshape files, a
        blendshape whose vertex count or faces differ from the neutral's (the first such file), or whose
        vertices are clearly in another order (`_VertexOrder`), two files with one stem, a malformed
        line, a non-finite coordinate; an ``*.obj`` entry that is not a regular file inside the folder
        (a FIFO, a device, a dangling or looping link, a link outside: see :func:`rigs._safe.rig_entries`);
        a ``rig.json`` that is not JSON, has fields of the wrong type, or names files outside the folder.

    Warns
    -----
    RigWarning
        For ``*.obj`` files that ``rig.json`` does not list (left out), and for a blendshape that looks
        doubtful (`_VertexOrder`: edges rescaled wholesale, most vertices moved far).
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise RigError(f"{folder}: no such folder of OBJ files")
    manifest = _read_manifest(folder)
    entries = rig_entries(folder, _is_obj_name, recursive=False)
    neutral_path = _neutral_path(folder, entries, neutral, manifest.get("neutral"))
    shape_paths = _shape_paths(folder, entries, neutral_path, manifest.get("shapes"))
    if not shape_paths and "shapes" not in manifest:  # (a rig.json may list none, as written)
        shape_paths = _subfolder_shape_paths(folder, neutral_path)

    outside = neutral is not None and Path(neutral).is_absolute()  # (an explicit path may be elsewhere)
    base = read_obj(neutral_path, root=None if outside else folder)
    if not base.faces:
        raise RigError(f"{neutral_path}: the neutral mesh has no faces")
    n_vertices = len(base.vertices)
    files = sum(_file_size(path, folder) for path in shape_paths.values())
    check_budget(
        str(folder),
        f"{len(shape_paths)} blendshapes of {n_vertices} vertices",
        len(shape_paths) * n_vertices * 3 * 8,
        files,
    )
    triangles = triangulate(base.faces, base.vertices)
    edges = _VertexOrder(base.vertices, triangles, neutral_path)
    deltas = np.empty((len(shape_paths), n_vertices, 3))
    step = decimal_step(base.vertices)
    for k, (path, shape) in enumerate(_read_shapes(shape_paths.values(), base, folder)):
        _check_same_mesh(base, shape, path, neutral_path)
        edges.check(shape.vertices, path)
        np.subtract(shape.vertices, base.vertices, out=deltas[k])
        step = max(step, decimal_step(shape.vertices))

    meta = {"source": str(folder), "format": "obj-folder", "neutral": neutral_path.name}
    meta["units"] = manifest.get("units", "unknown")
    meta["decimal_step"] = step
    return Rig(
        neutral=base.vertices,
        deltas=deltas,
        triangles=triangles,
        names=tuple(shape_paths),
        regions=dict(manifest.get("regions", {})),
        faces=None if faces_are_triangles(base.faces) else base.faces,
        meta=meta,
    )


def _read_shapes(paths: Iterable[Path], base: ObjMesh, folder: Path) -> Iterator[tuple[Path, ObjMesh]]:
    """Each blendshape OBJ of ``paths`` read against the neutral ``base``, in order.

    Up to `_READERS` files are read at once in threads, at most twice as many ahead of the caller (their
    reading and parsing run mostly outside the interpreter lock); a file's error is raised when its turn
    comes, so the first bad file in order is the one named.
    """
    paths = list(paths)
    read = partial(read_obj, with_faces=False, faces_of=base, root=folder)
    if _READERS < 2 or len(paths) < 2:
        yield from ((path, read(path)) for path in paths)
        return
    waiting = iter(paths)
    with ThreadPoolExecutor(_READERS) as pool:
        reading: deque[tuple[Path, Future[ObjMesh]]] = deque()

        def read_next() -> None:
            for path in islice(waiting, 1):
                reading.append((path, pool.submit(contextvars.copy_context().run, read, path)))

        for _ in range(2 * _READERS):
            read_next()
        try:
            while reading:
                path, future = reading.popleft()
                shape = future.result()
                read_next()
                yield path, shape
        finally:
            for _, future in reading:
                future.cancel()


class _VertexOrder:
    """Tells a blendshape that lists the neutral's vertices in another order from a real expression.

    A shuffled vertex order passes every count check but turns each delta into the distance between two
    unrelated vertices. Its mark is that the mesh's edges, measured in the shape, change length wholesale:
    an expression stretches the edges of the region it moves and leaves the others alone (in the
    generated rigs at most 0.4 % of edges change length more than 4 times, and at most 10 % by more than
    25 %), while a shuffled order changes most edges by a factor of ten or more.

    * More than half of the edges changing length more than `PERMUTED` times: `RigError`, the order
      differs (the shape cannot be read correctly).
    * More than half changing by more than `DOUBTFUL`: `RigWarning` (a rescaled shape, or an order
      only partly shuffled), and the shape is loaded.
    * More than half of the vertices moving further than `FAR` times the neutral's bounding-box diagonal
      (edges intact: a mirrored or rotated numbering of a symmetric mesh, or another mesh's shape):
      `RigWarning`, and the shape is loaded.
    """

    PERMUTED = 4.0
    DOUBTFUL = 1.25
    FAR = 0.25

    def __init__(self, neutral: np.ndarray, triangles: np.ndarray, neutral_path: Path) -> None:
        pairs = np.sort(triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
        keys = np.unique(pairs[:, 0] * len(neutral) + pairs[:, 1])  # (sorted as the pairs are)
        edges = np.stack([keys // len(neutral), keys % len(neutral)], axis=1)
        rest = vector_lengths(neutral[edges[:, 0]] - neutral[edges[:, 1]])
        self.edges, self.rest = edges[rest > 0], rest[rest > 0]
        self.first, self.second = self.edges[:, 0].copy(), self.edges[:, 1].copy()  # (contiguous: faster)
        self.neutral = neutral
        self.far = self.FAR * float(np.linalg.norm(np.ptp(neutral, axis=0)))
        self.neutral_path = neutral_path

    def check(self, shape: np.ndarray, path: Path) -> None:
        """Raise or warn as the class says; only the edges and vertices the shape moves are measured (the
        others keep their length and place exactly)."""
        if not len(self.edges):
            return
        differs = shape != self.neutral
        moved = differs[:, 0] | differs[:, 1] | differs[:, 2]
        touched = np.flatnonzero(moved[self.first] | moved[self.second])
        length = vector_lengths(shape[self.first[touched]] - shape[self.second[touched]])
        with np.errstate(divide="ignore"):
            change = np.abs(np.log(length / self.rest[touched]))
        permuted = np.count_nonzero(change > np.log(self.PERMUTED)) / len(self.edges)
        if permuted > 0.5:
            raise RigError(
                f"{path}: its vertices are not in the order of the neutral {self.neutral_path.name} "
                f"({permuted:.0%} of the mesh's edges change length more than {self.PERMUTED:g} times); "
                "a blendshape must list the neutral's vertices in the same order"
            )
        doubtful = np.count_nonzero(change > np.log(self.DOUBTFUL)) / len(self.edges)
        distance = vector_lengths(shape[moved] - self.neutral[moved])
        far = np.count_nonzero(distance > self.far) / len(shape)
        if far > 0.5:
            warnings.warn(
                f"{path}: {far:.0%} of its vertices move further than {self.FAR:g} of the neutral's size "
                f"from the neutral {self.neutral_path.name} (another mesh's shape, or vertices in another "
                "order?)",
                RigWarning,
                stacklevel=4,
            )
        if doubtful > 0.5:
            warnings.warn(
                f"{path}: {doubtful:.0%} of the mesh's edges change length by more than "
                f"{self.DOUBTFUL - 1:.0%} against the neutral {self.neutral_path.name} (a rescaled shape, "
                "or vertices in another order?)",
                RigWarning,
                stacklevel=4,
            )


def _is_obj_name(name: str) -> bool:
    return Path(name).suffix.lower() == ".obj"


def _file_size(path: Path, folder: Path) -> int:
    try:
        return regular_file(path, folder)
    except UnreadableFile as error:
        raise RigError(f"{path}: cannot read OBJ file ({error.reason})") from None


def load_obj_neutral(path: str | Path) -> Rig:
    """The rig of the folder holding the neutral OBJ ``path``; the folder's other OBJ files are blendshapes.

    Raises
    ------
    RigError
        When the folder names another file as its neutral (``rig.json``, ``neutral.obj`` or one of
        `NEUTRAL_STEMS`): ``path`` is then a blendshape, and taking it as the neutral would turn every
        delta into a difference from that expression.
    """
    path = Path(path)
    folder = path.parent
    manifest = _read_manifest(folder)
    entries = rig_entries(folder, _is_obj_name, recursive=False)
    try:
        declared = _neutral_path(folder, entries, None, manifest.get("neutral"))
    except RigError:
        declared = None
    if declared is not None and os.path.realpath(declared) != os.path.realpath(path):
        raise RigError(
            f"{path}: not the neutral of its folder ({declared.name} is); load {declared} or the folder"
        )
    return load_obj_folder(folder, neutral=path.name)


def _read_manifest(folder: Path) -> dict:
    path = folder / MANIFEST
    if not os.path.lexists(path):
        return {}
    text = read_text(path, root=folder, limit=MANIFEST_LIMIT, why="a rig manifest")
    try:
        manifest = json.loads(text)
    except (ValueError, RecursionError) as error:
        raise RigError(f"{path}: not a readable JSON manifest ({type(error).__name__}: {error})") from None
    if not isinstance(manifest, dict) or not isinstance(manifest.get("shapes", []), list):
        raise RigError(f"{path}: expected an object with a 'shapes' list of blendshape names")
    for key, kind, what in (
        ("neutral", str, "a file name"),
        ("units", str, "a string"),
        ("regions", dict, "an object of region name -> vertex indices"),
    ):
        if key in manifest and not isinstance(manifest[key], kind):
            raise RigError(f"{path}: '{key}' must be {what}, got {manifest[key]!r:.60}")
    return manifest


def _neutral_path(folder: Path, entries: list[Path], option: str | Path | None, declared: object) -> Path:
    """The neutral's path: ``option`` (the caller's), else ``declared`` (``rig.json``'s), else the default."""
    if option is None and declared is None and folder / "neutral.obj" not in entries:
        named = [p for p in entries if p.stem.lower() in NEUTRAL_STEMS]
        if len(named) > 1:
            listed = ", ".join(p.name for p in named)
            raise RigError(f"{folder}: several OBJ files could be the neutral ({listed}); pass neutral=NAME")
        if named:
            return named[0]
    if option is not None:
        path = Path(option) if Path(option).is_absolute() else folder / option
    elif declared is not None:
        path = named_path(folder, declared, str(folder / MANIFEST))
    else:
        path = folder / "neutral.obj"
    if path.suffix.lower() != ".obj" and not os.path.lexists(path):
        path = path.with_name(path.name + ".obj")
    if not os.path.lexists(path):
        present = [p.name for p in entries][:5]
        hint = f"; OBJ files here: {', '.join(present)}" if present else "; the folder has no OBJ files"
        raise RigError(
            f"{path}: neutral mesh not found (pass neutral=NAME, or load the neutral OBJ's path){hint}"
        )
    return path


def _subfolder_shape_paths(folder: Path, neutral_path: Path) -> dict[str, Path]:
    """The blendshapes of an export that puts the neutral at the top and the shapes in one subfolder
    (``shapes/``, ``blendshapes/``, ``targets/``, ...): that subfolder's OBJs, named by their stems.

    Raises
    ------
    RigError
        When no subfolder, or more than one, holds OBJ files.
    """
    with os.scandir(folder) as found:
        subfolders = sorted(
            Path(entry.path)
            for entry in found
            if entry.is_dir(follow_symlinks=False) and entry.name[:1] != "."
        )
    holding = {sub: rig_entries(sub, _is_obj_name, recursive=False) for sub in subfolders}
    holding = {sub: entries for sub, entries in holding.items() if entries}
    if len(holding) != 1:
        where = (
            f"its subfolders {', '.join(sub.name for sub in holding)} all hold OBJ files; give the shapes "
            "in one folder"
            if holding
            else "its folder has no other OBJ files and no subfolder of them"
        )
        raise RigError(f"{neutral_path}: one OBJ holds no blendshapes, and {where} (one OBJ per blendshape)")
    ((subfolder, entries),) = holding.items()
    for path in entries:  # inside the rig's folder, not only inside the subfolder
        regular_file(path, folder)
    return _shape_paths(subfolder, entries, neutral_path, None)


def _shape_paths(
    folder: Path, entries: list[Path], neutral_path: Path, listed: list | None
) -> dict[str, Path]:
    neutral_real = os.path.realpath(neutral_path)
    if listed is None:
        paths: dict[str, Path] = {}
        for path in entries:
            if os.path.realpath(path) == neutral_real:
                continue
            if path.stem in paths:
                raise RigError(
                    f"{path}: duplicate blendshape name {path.stem!r} (also {paths[path.stem].name})"
                )
            paths[path.stem] = path
        return paths
    origin = folder / MANIFEST
    paths = {}
    for name in listed:
        if not isinstance(name, str) or not name:
            raise RigError(f"{origin}: blendshape names must be non-empty strings, got {name!r:.60}")
        if name in paths:
            raise RigError(f"{origin}: duplicate blendshape name {name!r}")
        paths[name] = named_path(folder, f"{name}.obj", str(origin))
    missing = [path for path in paths.values() if not os.path.lexists(path)]
    if missing:
        raise RigError(f"{missing[0]}: blendshape listed in {MANIFEST} but the file is missing")
    chosen = {os.path.realpath(path) for path in paths.values()} | {neutral_real}
    unlisted = [path.name for path in entries if os.path.realpath(path) not in chosen]
    if unlisted:
        shown = ", ".join(unlisted[:5]) + (f" and {len(unlisted) - 5} more" if len(unlisted) > 5 else "")
        warnings.warn(
            f"{folder}: {shown} not listed in {MANIFEST}'s shapes; left out", RigWarning, stacklevel=4
        )
    return paths


def _check_same_mesh(base: ObjMesh, shape: ObjMesh, path: Path, neutral_path: Path) -> None:
    if len(shape.vertices) != len(base.vertices):
        expected = len(base.vertices)
        raise RigError(
            f"{path}: {len(shape.vertices)} vertices, but the neutral {neutral_path.name} has {expected}"
        )
    if not shape.face_lines or shape.face_lines == base.face_lines:
        return
    faces = read_obj(path, root=neutral_path.parent).faces
    if len(faces) != len(base.faces):
        raise RigError(
            f"{path}: {len(faces)} faces, but the neutral {neutral_path.name} has {len(base.faces)}"
        )
    for index, (mine, theirs) in enumerate(zip(faces, base.faces, strict=True)):
        if not np.array_equal(mine, theirs):
            raise RigError(
                f"{path}: connectivity differs from the neutral {neutral_path.name} at face {index} "
                f"({(mine + 1).tolist()} vs {(theirs + 1).tolist()})"
            )


def _face_lines(faces: np.ndarray | Sequence[np.ndarray]) -> bytes:
    """``f`` lines (1-based, ASCII) of a (T, 3) array of triangles or of a sequence of polygons."""
    if isinstance(faces, np.ndarray) or faces_are_triangles(faces):
        return triangle_lines(np.asarray(faces, dtype=np.int64).reshape(-1, 3))
    return "".join("f " + " ".join(map(str, (face + 1).tolist())) + "\n" for face in faces).encode("ascii")


def write_obj(
    path: str | Path, vertices: np.ndarray, faces: Sequence[np.ndarray], *, comment: str = ""
) -> None:
    """Write one OBJ: ``v`` lines with shortest round-trip floats, then 1-based ``f`` lines."""
    header = "".join(f"# {line}\n" for line in comment.splitlines()).encode("utf-8")
    Path(path).write_bytes(header + vertex_lines(np.asarray(vertices)) + _face_lines(faces))


def save_obj_folder(rig: Rig, folder: str | Path) -> Path:
    """Write a rig as a folder of OBJs that other tools can read.

    Writes ``neutral.obj``, one ``<name>.obj`` per blendshape with absolute positions ``neutral + delta``,
    and ``rig.json`` (shape order, regions, units) so :func:`load_obj_folder` restores the same rig up to
    float rounding of ``(neutral + delta) - neutral``. Polygons are written from ``rig.faces`` when present,
    else the triangles.

    Raises
    ------
    RigError
        When a blendshape name cannot be a file name (path separators, reserved characters, ``neutral``,
        names equal up to case), or when the folder already holds other OBJ files.
    """
    folder = Path(folder)
    _check_file_names(rig.names, folder)
    wanted = {"neutral.obj", MANIFEST} | {f"{name}.obj" for name in rig.names}
    if folder.exists():
        if not folder.is_dir():
            raise RigError(f"{folder}: exists and is not a folder")
        strangers = sorted(
            p.name for p in folder.iterdir() if p.suffix.lower() == ".obj" and p.name not in wanted
        )
        if strangers:
            listed = ", ".join(strangers[:3])
            raise RigError(f"{folder}: already holds other OBJ files ({listed}); choose an empty folder")
    folder.mkdir(parents=True, exist_ok=True)
    face_text = _face_lines(rig.faces if rig.faces is not None else rig.triangles)
    source = rig.meta.get("source", "rig")
    (folder / "neutral.obj").write_bytes(
        f"# neutral of {source}\n".encode() + vertex_lines(rig.neutral) + face_text
    )
    for name, delta in zip(rig.names, rig.deltas, strict=True):
        header = f"# blendshape {name} of {source}\n".encode()
        (folder / f"{name}.obj").write_bytes(header + vertex_lines(rig.neutral + delta) + face_text)
    manifest = {
        "format": "obj-folder",
        "neutral": "neutral.obj",
        "shapes": list(rig.names),
        "regions": {name: indices.tolist() for name, indices in rig.regions.items()},
        "units": rig.meta.get("units", "unknown"),
    }
    (folder / MANIFEST).write_text(json.dumps(manifest, indent=1) + "\n", encoding="utf-8")
    return folder


def _check_file_names(names: Sequence[str], folder: Path) -> None:
    folded: dict[str, str] = {"neutral": "neutral"}
    for name in names:
        if _UNSAFE_NAME.search(name) or name in (".", "..") or name != name.strip():
            raise RigError(f"{folder}: blendshape name {name!r} cannot be an OBJ file name")
        if name.casefold() in folded:
            raise RigError(
                f"{folder}: blendshape name {name!r} collides with {folded[name.casefold()]!r} as a file name"
            )
        folded[name.casefold()] = name


# -- surfaces: an OBJ's own text around new positions ------------------------------------------------------
@dataclass(frozen=True, eq=False)
class ObjSurface:
    """Everything an OBJ file says besides its vertex positions, to write the same mesh at other positions.

    Texture coordinates (``vt``), normals (``vn``), groups (``g``, ``o``, ``s``), material references
    (``mtllib``, ``usemtl``), comments and the face corners (``f v/vt/vn``) are kept as written; only the
    ``v`` lines are replaced, in order, so vertex ``i`` of a rig read from the file stays line ``i``.

    Attributes
    ----------
    lines : tuple of str
        The file's logical lines (continuations joined, line ends normalised), ``v`` lines included.
    vertex_rows : (N,) int array
        Index in ``lines`` of each ``v`` line, in file order.
    vertex_tails : tuple of str
        What each ``v`` line holds after ``x y z`` (a ``w`` or vertex colours), ``""`` for most files.
    source : str
        The file it came from, for messages.
    """

    lines: tuple[str, ...]
    vertex_rows: np.ndarray
    vertex_tails: tuple[str, ...]
    source: str
    #: (step, single) -> the body first written with those settings.
    _written: dict[tuple[float, bool], _WrittenBody] = field(default_factory=dict, init=False, repr=False)

    @property
    def n_vertices(self) -> int:
        """Number of ``v`` lines."""
        return len(self.vertex_rows)

    def count(self, keyword: str) -> int:
        """Number of lines starting with ``keyword`` (``vt``, ``vn``, ``f``, ``g``, ``usemtl``, ...)."""
        return sum(1 for line in self.lines if line.split(None, 1)[:1] == [keyword])

    def text(
        self, vertices: np.ndarray, *, step: float = 0.0, single: bool = False, comment: str = ""
    ) -> str:
        """The file's text with its ``v`` lines at ``vertices``: `data` as text."""
        return self.data(vertices, step=step, single=single, comment=comment).decode("utf-8")

    def data(
        self, vertices: np.ndarray, *, step: float = 0.0, single: bool = False, comment: str = ""
    ) -> bytes:
        """The file (UTF-8) with its ``v`` lines at ``vertices`` (see `coordinate_lines` for the format),
        after the lines of ``comment`` as ``#`` comments.

        The first positions written with given ``step`` and ``single`` are kept with the whole text; later
        positions rewrite only the lines of the vertices whose values differ from them (an expression moves
        part of the face, and a line's text depends on its own values alone).

        Raises
        ------
        ValueError
            When ``vertices`` is not (N, 3) for the file's N ``v`` lines.
        """
        vertices = np.asarray(vertices, dtype=np.float64)
        if vertices.shape != (self.n_vertices, 3):
            raise ValueError(
                f"{self.source}: {self.n_vertices} 'v' lines, got positions of shape {vertices.shape}"
            )
        header = "".join(f"# {line}\n" for line in comment.splitlines()).encode("utf-8")
        written = self._written.get((step, single))
        if written is None:
            written = self._written[step, single] = self._write_all(vertices, step, single)
            return header + written.body
        changed = written.changed(vertices)
        if not len(changed):
            return header + written.body
        return b"".join([header, *written.rewritten(changed, self._block(vertices, step, single, changed))])

    def _block(
        self, vertices: np.ndarray, step: float, single: bool, which: np.ndarray | None = None
    ) -> _LineBlock:
        """The ``v`` lines of ``vertices`` (only those of the indices ``which``), with their tails."""
        picked = vertices if which is None else vertices[which]
        if not any(self.vertex_tails):
            return _LineBlock.of(coordinate_block(picked, step=step, single=single))
        tails = self.vertex_tails if which is None else [self.vertex_tails[i] for i in which.tolist()]
        rows = coordinate_lines(picked, step=step, single=single)
        lines = "".join(f"{row}{tail}\n" for row, tail in zip(rows, tails, strict=True))
        return _LineBlock.of(lines.encode("utf-8"))

    def _write_all(self, vertices: np.ndarray, step: float, single: bool) -> _WrittenBody:
        """The whole body at ``vertices``, with where each ``v`` line stands in it."""
        block = self._block(vertices, step, single)
        first, stop, gaps = self._runs
        pieces = [gaps[0]]
        for run, (begin, end) in enumerate(zip(first.tolist(), stop.tolist(), strict=True)):
            pieces += [block.data[block.starts[begin] : block.ends[end - 1] + 1], gaps[run + 1]]
        # each run of v lines stands in the body after the gaps before it and the runs before it
        run_offsets = np.cumsum([0, *(len(piece) for piece in pieces[:-1])])[1::2]
        offsets = np.repeat(run_offsets - block.starts[first], stop - first)
        return _WrittenBody(vertices.copy(), b"".join(pieces), block.starts + offsets, block.ends + offsets)

    @cached_property
    def _runs(self) -> tuple[np.ndarray, np.ndarray, list[bytes]]:
        """The runs of consecutive ``v`` lines (first vertex and one past the last of each) and the text
        of the other lines around them (before each run, and after the last), each line with its line
        feed, as UTF-8."""
        rows = np.asarray(self.vertex_rows, dtype=np.int64)
        first = np.flatnonzero(np.diff(rows, prepend=-2) != 1)
        stop = np.append(first[1:], len(rows))
        gap_starts = [0, *(rows[stop - 1] + 1).tolist()]
        gap_stops = [*rows[first].tolist(), len(self.lines)]
        chunks = [self.lines[start:end] for start, end in zip(gap_starts[:-1], gap_stops[:-1], strict=True)]
        tail = self.lines[gap_starts[-1] :]
        chunks.append(tail[:-1] if tail and tail[-1] == "" else tail)  # (a last empty line: a line feed)
        return first, stop, [("\n".join(chunk) + "\n").encode("utf-8") if chunk else b"" for chunk in chunks]


@dataclass(frozen=True)
class _LineBlock:
    """Lines of text, each ending in a line feed (UTF-8), and where line ``i`` starts and ends (its line
    feed) in ``data``."""

    data: bytes
    starts: np.ndarray
    ends: np.ndarray

    @classmethod
    def of(cls, data: bytes) -> _LineBlock:
        ends = np.flatnonzero(np.frombuffer(data, dtype=np.uint8) == ord("\n"))
        starts = np.zeros(len(ends), dtype=np.int64)
        starts[1:] = ends[:-1] + 1
        return cls(data, starts, ends)


@dataclass(frozen=True)
class _WrittenBody:
    """An `ObjSurface`'s body written once at ``reference`` positions, and the span ``[starts, ends)`` of
    each ``v`` line in it (``ends``: its line feed): other positions rewrite only the lines whose values
    differ (bit for bit)."""

    reference: np.ndarray
    body: bytes
    starts: np.ndarray
    ends: np.ndarray

    def changed(self, vertices: np.ndarray) -> np.ndarray:
        """Indices of the vertices whose positions differ from the reference."""
        different = vertices.view(np.int64) != self.reference.view(np.int64)
        return np.flatnonzero(different[:, 0] | different[:, 1] | different[:, 2])

    def rewritten(self, changed: np.ndarray, block: _LineBlock) -> list[bytes]:
        """The pieces of the body with the ``v`` lines of the vertices ``changed`` (ascending, at least one)
        replaced by the lines of ``block``: a run of changed lines that follow each other in the body is
        one piece."""
        follows = self.ends[changed[:-1]] + 1 == self.starts[changed[1:]]
        first = np.flatnonzero(np.concatenate([[True], ~follows]))
        last = np.append(first[1:] - 1, len(changed) - 1)
        kept_from = [0, *self.ends[changed[last]].tolist()]
        kept_to = [*self.starts[changed[first]].tolist(), len(self.body)]
        pieces: list[bytes] = [b""] * (2 * len(first) + 1)
        pieces[0::2] = [self.body[start:end] for start, end in zip(kept_from, kept_to, strict=True)]
        pieces[1::2] = [
            block.data[start:end]
            for start, end in zip(block.starts[first].tolist(), block.ends[last].tolist(), strict=True)
        ]
        return pieces


def parse_surface(text: str, source: str) -> ObjSurface:
    """The `ObjSurface` of OBJ text (the positions themselves are read by :func:`parse_obj`).

    Raises
    ------
    RigError
        For a ``v`` line without three values (``source:line: ...``) or a file without ``v`` lines.
    """
    if "\r" in text:
        text = text.replace("\r\n", "\n").replace("\r", "\n")
    lines = [line for _, line in _numbered_lines(text)]
    if lines and lines[-1] == "":
        lines.pop()
    plain = _plain_surface(text, lines, source)
    if plain is not None:
        return plain
    rows, tails = [], []
    for index, line in enumerate(lines):
        if line[:1] != "v" and not line[:1].isspace():  # (its first word is not "v")
            continue
        parts = line.split(None, 4)
        if parts[:1] != ["v"]:
            continue
        if len(parts) < 4:
            raise RigError(f"{source}:{index + 1}: vertex needs x y z, got {line.strip()[:80]!r}")
        rows.append(index)
        tails.append(" " + parts[4] if len(parts) > 4 else "")
    if not rows:
        raise RigError(f"{source}: no vertices ('v' lines)")
    return ObjSurface(tuple(lines), np.asarray(rows, dtype=np.int64), tuple(tails), source)


def _plain_surface(text: str, lines: list[str], source: str) -> ObjSurface | None:
    """`parse_surface` in one go for a plain file (as `_vertices_only` tells plain files) whose ``v``
    lines are all ``v x y z`` (no tails), else None."""
    if not _plain_characters(text):
        return None
    starts = list(map(_FIRST_TWO, lines))
    if not _plain_starts(set(starts)):
        return None
    rows = [index for index, start in enumerate(starts) if start == "v "]
    if not rows or read_vertex_lines("".join(lines[index] + "\n" for index in rows)) is None:
        return None
    return ObjSurface(tuple(lines), np.asarray(rows, dtype=np.int64), ("",) * len(rows), source)


def read_surface(path: str | Path, *, root: str | Path | None = None) -> ObjSurface:
    """The `ObjSurface` of an OBJ file (inside ``root`` when given, see :mod:`rigs._safe`).

    Raises
    ------
    RigError
        When the file cannot be read or has no ``v`` lines.
    """
    path = Path(path)
    try:
        text = read_text(path, root=None if root is None else Path(root))
    except UnreadableFile as error:
        raise RigError(f"{path}: cannot read OBJ file ({error.reason})") from None
    return parse_surface(text, str(path))


def coordinate_lines(vertices: np.ndarray, *, step: float = 0.0, single: bool = False) -> list[str]:
    """``v x y z`` lines at the precision of the source (`coordinate_block`, one string per line)."""
    return coordinate_block(vertices, step=step, single=single).decode("ascii").split("\n")[:-1]


def coordinate_block(vertices: np.ndarray, *, step: float = 0.0, single: bool = False) -> bytes:
    """``v x y z`` lines at the precision of the source, each ending in a line feed (ASCII).

    Parameters
    ----------
    vertices : (N, 3) array
    step : float
        The source's rounding step (`decimal_step`): coordinates are written with its fixed number of
        decimals, so a sum such as ``7.2296 + 0.0`` prints as ``7.2296``, not ``7.2296000000000005``.
    single : bool
        Without a step: the source holds single-precision floats (glTF), written as the shortest text
        that reads back as the same float32. Otherwise the shortest round-trip float64 text.
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    if step > 0:
        decimals = max(0, round(-math.log10(step)))
        values = np.round(vertices, decimals) + 0.0  # (+ 0.0 turns -0.0 into 0.0)
        line = f"v %.{decimals}f %.{decimals}f %.{decimals}f\n"
        return (line * len(values) % tuple(values.ravel())).encode("ascii")
    return vertex_lines(vertices, single=single)


def rig_surface(rig: Rig) -> ObjSurface | None:
    """The OBJ a rig's vertices come from, when it is known and still matches them, else None.

    ``meta["surface"]`` names it (the Face Units rig keeps its cropped base mesh there); a rig read from
    a folder of OBJs has its neutral OBJ. The file must have the rig's vertex count and its positions
    must be the rig's neutral (up to the file's rounding), so that writing the rig's positions into it
    keeps every other line right.
    """
    meta = rig.meta
    if meta.get("surface"):
        path, root = Path(meta["surface"]), None
    elif meta.get("format") == "obj-folder" and meta.get("neutral") and meta.get("source"):
        root = Path(meta["source"])
        path = root / meta["neutral"]
    else:
        return None
    if not path.is_file():
        return None
    surface = read_surface(path, root=root)
    if surface.n_vertices != rig.n_vertices:
        return None
    lines = [surface.lines[i] for i in surface.vertex_rows]
    positions = _plain_vertex_block("".join(line + "\n" for line in lines))
    if positions is None:
        positions = _read_rows(lines)
    if positions is None or not (np.abs(positions) <= LARGEST_COORDINATE).all():
        positions = parse_obj("\n".join(lines), str(path)).vertices  # (raises, naming the line)
    tolerance = max(float(meta.get("decimal_step", 0.0) or 0.0), 1e-6 * rig.diagonal())
    return surface if np.abs(positions - rig.neutral).max() <= tolerance else None


def crop_surface(text: str, source: str, kept: np.ndarray) -> str:
    """The OBJ text of the part of a mesh on the vertices ``kept``, every other line kept as written.

    The faces whose corners are all kept stay (with their texture and normal indices renumbered to the
    ``vt``/``vn`` lines they still use); ``v``, ``vt`` and ``vn`` lines no kept face uses are dropped
    (``v`` lines in ``kept`` stay, in file order, so vertex ``i`` of the result is ``kept[i]``); lines of
    points and polylines (``p``, ``l``) are dropped, and so are ``g``, ``o`` and ``usemtl`` lines that no
    kept face follows before the next line of their kind; smoothing, material libraries and comments stay.

    Parameters
    ----------
    text : str
        The OBJ file's text.
    source : str
        Its name, for messages.
    kept : int array
        Sorted 0-based indices of the vertices to keep.

    Raises
    ------
    RigError
        For a malformed face corner or an index outside the file's lines.
    """
    lines = [line for _, line in _numbered_lines(text.replace("\r\n", "\n").replace("\r", "\n"))]
    counts = {"v": 0, "vt": 0, "vn": 0}
    faces: list[tuple[int, list[list[int]]]] = []  # (line, corners as [v, vt, vn] 0-based, -1 absent)
    for number, line in enumerate(lines):
        parts = line.split("#", 1)[0].split()
        if not parts:
            continue
        if parts[0] in counts:
            counts[parts[0]] += 1
        elif parts[0] == "f":
            corners = []
            for token in parts[1:]:
                fields = (token.split("/") + ["", ""])[:3]
                try:
                    corner = [
                        -1 if not field else int(field) - 1 if int(field) > 0 else counts[key] + int(field)
                        for field, key in zip(fields, ("v", "vt", "vn"), strict=True)
                    ]
                except ValueError:
                    raise RigError(f"{source}:{number + 1}: malformed face corner {token!r:.40}") from None
                corners.append(corner)
            faces.append((number, corners))
    keep_vertex = np.zeros(counts["v"], dtype=bool)
    keep_vertex[np.asarray(kept, dtype=np.int64)] = True
    used = {"vt": np.zeros(counts["vt"], dtype=bool), "vn": np.zeros(counts["vn"], dtype=bool)}
    kept_faces = {}
    for number, corners in faces:
        array = np.asarray(corners, dtype=np.int64).reshape(-1, 3)
        for column, (key, size) in enumerate(
            (("v", counts["v"]), ("vt", counts["vt"]), ("vn", counts["vn"]))
        ):
            present = array[:, column][array[:, column] >= 0] if column else array[:, 0]
            if (present < 0).any() or (present >= size).any():
                raise RigError(f"{source}:{number + 1}: face indexes a {key} line outside 1..{size}")
        if keep_vertex[array[:, 0]].all():
            kept_faces[number] = array
            for column, key in ((1, "vt"), (2, "vn")):
                used[key][array[:, column][array[:, column] >= 0]] = True
    renumber = {key: np.cumsum(mask) for key, mask in (("v", keep_vertex), *used.items())}
    masks = {"v": keep_vertex, **used}
    seen = {"v": 0, "vt": 0, "vn": 0}
    out = []
    for number, line in enumerate(lines):
        keyword = line.split(None, 1)[:1]
        keyword = keyword[0] if keyword else ""
        if keyword in seen:
            index = seen[keyword]
            seen[keyword] += 1
            if masks[keyword][index]:
                out.append(line)
        elif keyword == "f":
            if number in kept_faces:
                out.append("f " + " ".join(_corner(row, renumber) for row in kept_faces[number].tolist()))
        elif keyword not in ("l", "p"):
            out.append(line)
    return "\n".join(_without_empty_states(out)).rstrip("\n") + "\n"


def _without_empty_states(lines: list[str]) -> list[str]:
    """``lines`` less the ``g``, ``o`` and ``usemtl`` lines whose state no face line uses."""
    states = ("g", "o", "usemtl")
    faced = dict.fromkeys(states, False)  # a face follows, before the next line of the kind (walking back)
    kept = []
    for line in reversed(lines):
        keyword = line.split(None, 1)[:1]
        keyword = keyword[0] if keyword else ""
        if keyword == "f":
            faced = dict.fromkeys(states, True)
        elif keyword in states:
            if not faced[keyword]:
                continue
            faced[keyword] = False
        kept.append(line)
    return kept[::-1]


def _corner(row: list[int], renumber: dict[str, np.ndarray]) -> str:
    """One ``v/vt/vn`` face corner with 1-based renumbered indices (absent parts left empty)."""
    vertex, texture, normal = row
    text = str(int(renumber["v"][vertex]))
    if texture < 0 and normal < 0:
        return text
    text += "/" + (str(int(renumber["vt"][texture])) if texture >= 0 else "")
    return text + ("/" + str(int(renumber["vn"][normal])) if normal >= 0 else "")


def plain_surface(rig: Rig) -> ObjSurface:
    """The `ObjSurface` of what a rig itself holds: its vertices and its polygons (``rig.faces``, else the
    triangles), for rigs that do not come from an OBJ."""
    faces = rig.faces if rig.faces is not None else rig.triangles
    lines = ["v 0 0 0"] * rig.n_vertices + _face_lines(faces).decode("ascii").splitlines()
    source = str(rig.meta.get("source", "rig"))
    return ObjSurface(tuple(lines), np.arange(rig.n_vertices), ("",) * rig.n_vertices, source)
