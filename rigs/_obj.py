"""Wavefront OBJ text: one mesh's positions, polygons and face groups.

A file is read in blocks of about `BLOCK_BYTES` (cut after a line end, never inside a continued line), each
in one go with numpy and Arrow when it is plain, else line by line, naming the line at fault
(`rigs._obj_block`). Only a block's text and what it holds are in memory at once besides the file's bytes
and what is read from it, so a read takes a small multiple of the file's size, whatever its lines.
"""

from __future__ import annotations

import codecs
import hashlib
from array import array
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rigs._obj_block import (
    DECIMAL,
    BlockPart,
    is_continued,
    is_plain,
    line_block,
    numbered_lines,
    plain_block,
)
from rigs._obj_faces import INDEX_KINDS, Polygons
from rigs._obj_layout import NeutralLayout
from rigs._rig import RigError
from rigs._safe import UnreadableFile, read_bytes, size_text

__all__ = ["DECIMAL", "ObjMesh", "decimal_step", "numbered_lines", "parse_obj", "read_obj"]

#: Bytes of text read as one block.
BLOCK_BYTES = 2**20
#: Decimal places `decimal_step` takes for rounding: coordinates with fewer are a design grid (integers,
#: halves), not rounded; more than 9 is below any noise floor.
_ROUNDING_DECIMALS = range(3, 10)
#: Coordinates sampled per file by `decimal_step`.
_STEP_SAMPLE = 3000


@dataclass(frozen=True, eq=False)
class ObjMesh:
    """Geometry of one OBJ file.

    Attributes
    ----------
    vertices : (N, 3) float array
        One row per ``v`` line, in file order (texture and normal seams do not split vertices).
    faces : Polygons
        The polygons as 0-based vertex indices, in file order.
    groups : dict str -> int array
        Face indices of each ``g`` group (a face in several groups is listed in each).
    face_digest : bytes
        A digest of the corners of the ``f`` lines as written, for a fast identical-connectivity check
        (empty without ``f`` lines).
    layout : NeutralLayout or None
        Where the file's text holds its vertex lines and its face section (set by a full read of a file
        whose faces follow all its vertices and whose lines end in line feeds), so that blendshape files
        that repeat its face section are recognised without reading it, and those that repeat the rest of
        its text too are read by their vertex lines alone.
    """

    vertices: np.ndarray
    faces: Polygons = field(default_factory=Polygons.empty)
    groups: dict[str, np.ndarray] = field(default_factory=dict)
    face_digest: bytes = b""
    layout: NeutralLayout | None = None

    def group_vertices(self, name: str) -> np.ndarray:
        """Sorted vertex indices used by the faces of group ``name``."""
        faces = [self.faces[i] for i in self.groups[name]]
        return np.unique(np.concatenate(faces)) if faces else np.zeros(0, dtype=np.int64)


def parse_obj(
    text: str | bytes, source: str, *, with_faces: bool = True, faces_of: ObjMesh | None = None
) -> ObjMesh:
    """Read OBJ text: ``v`` positions and ``f`` polygons; everything else is skipped.

    Accepted: comments (``#`` to end of line), CRLF or CR line ends, ``\\`` line continuations,
    ``v x y z [w]`` and ``v x y z r g b`` (only the first three values are kept), scientific notation, face
    corners ``v``, ``v/vt``, ``v/vt/vn`` and ``v//vn``, negative (relative) indices, and the keywords
    ``vt vn vp o g s usemtl mtllib l p`` (only ``g`` is recorded; ``vt`` and ``vn`` lines are counted, and
    with ``with_faces`` texture coordinates are checked and every index of a corner is checked against its
    list).

    Parameters
    ----------
    text : str or bytes
        The file's content (bytes: UTF-8, undecodable bytes read as replacement characters, a leading
        byte-order mark skipped).
    source : str
        Name used in error messages (the file path).
    with_faces : bool
        When False, faces are not decoded (``faces`` is empty) but ``face_digest`` is still made.
    faces_of : ObjMesh, optional
        A fully read mesh (the neutral) whose face digest is reused when this file ends with its face
        section and has no face line before it (``with_faces=False`` only); when the file also repeats the
        neutral's text around a run of plain ``v x y z`` lines, only those are read
        (`rigs._obj_layout.NeutralLayout`).

    Raises
    ------
    RigError
        ``source:line: problem`` for a malformed vertex (other than 3, 4 or 6 values, a coordinate that is
        not an ASCII decimal number), texture coordinate or face, an index of 0 or outside its list (also
        past 64 bits), a face with more corners than the mesh has vertices, a non-finite coordinate or one
        beyond `rigs._rig.LARGEST_COORDINATE`, a ``g`` line naming more than 256 groups, or a file without
        vertices.
    """
    data = text.encode("utf-8", errors="surrogatepass") if isinstance(text, str) else bytes(text)
    if data.startswith(codecs.BOM_UTF8):  # (a byte-order mark, which Windows editors write)
        data = data[len(codecs.BOM_UTF8) :]
    if faces_of is not None and faces_of.layout is not None and not with_faces:
        shape = _shape(data, source, faces_of, faces_of.layout)
        if shape is not None:
            return shape
    reader = _Reader(source, with_faces=with_faces)
    reader.read(data)
    return reader.mesh(data)


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
        When the file is missing or cannot be read (not a regular file, outside ``root``), is malformed,
        or is too large to read in the memory available.
    """
    path = Path(path)
    try:
        data = read_bytes(path, root=None if root is None else Path(root))
        return parse_obj(data, str(path), with_faces=with_faces, faces_of=faces_of)
    except UnreadableFile as error:
        raise RigError(f"{path}: cannot read OBJ file ({error.reason})") from None
    except MemoryError:
        raise RigError(
            f"{path}: too large to read in the memory available ({size_text(path.stat().st_size)})"
        ) from None


def _shape(data: bytes, source: str, neutral: ObjMesh, layout: NeutralLayout) -> ObjMesh | None:
    """A blendshape file ``data`` that ends with the face section of its ``neutral`` (laid out as
    ``layout``) and has no face line before it, read by its vertex lines alone; None for any other file (to
    be read whole)."""
    face_start = layout.faces_at(data)
    if face_start is None:
        return None
    vertices = layout.shape_vertices(data, face_start, source)
    if vertices is None:
        reader = _Reader(source, with_faces=False)
        reader.read(data[:face_start])
        if reader.face_count:
            return None
        vertices = reader.vertices()
    return ObjMesh(vertices, face_digest=neutral.face_digest)


def _blocks(data: bytes) -> Iterator[bytes]:
    """``data`` in blocks of about `BLOCK_BYTES`, each cut after a line end (LF, CRLF or CR) that does not
    continue its line with ``\\``, with CRLF and CR line ends turned into LF."""
    carriage = b"\r" in data
    start = 0
    while start < len(data):
        stop = _cut(data, start + BLOCK_BYTES, carriage)
        block = data[start:stop]
        if carriage:
            block = block.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
        yield block
        start = stop


def _cut(data: bytes, at: int, carriage: bool) -> int:
    """Where a block ending at or after ``at`` stops: just past a line end whose line is not continued."""
    while at < len(data):
        end = data.find(b"\n", at)
        if carriage:
            lone = data.find(b"\r", at, len(data) if end < 0 else end)
            if lone >= 0 and lone != end - 1:  # (a CR line end, not the CR of a CRLF)
                end = lone
        if end < 0:
            break
        if not is_continued(data, end):
            return end + 1
        at = end + 1
    return len(data)


class _Reader:
    """The mesh of a file's blocks, read in order: positions and polygons gathered block by block, with
    what is checked once the whole file is known (indices past the end of their list, the largest face)."""

    def __init__(self, source: str, *, with_faces: bool) -> None:
        self.source = source
        self.with_faces = with_faces
        self.counts = [0, 0, 0]  # v, vt, vn lines so far
        self.face_count = 0
        # (arrays grown in place: a large one is moved by the system's realloc, never held twice)
        self.coordinates = array("d")
        self.sizes = array("q")  # (only once the polygons differ in size: see `uniform`)
        self.uniform = 0  # the corners of every polygon so far, while all have as many
        self.corners = array("q")
        self.digest = hashlib.blake2b(digest_size=32)
        #: (index, line number) of the largest index written of each kind, and of the largest face.
        self.furthest: list[tuple[int, int]] = [(0, 0)] * 4
        self.group_names: list[str] = []
        self.group_start = 0
        self.group_runs: list[tuple[int, int, list[str]]] = []
        self.first_face: tuple[int, int] | None = None  # (byte offset, vertices before it)

    def read(self, data: bytes) -> None:
        """Read every block of ``data``."""
        line, offset = 1, 0
        for block in _blocks(data):
            part = (
                plain_block(block, line, self.source, with_faces=self.with_faces) if is_plain(block) else None
            )
            if part is None:
                part = _line_block(block, line, self.source, self.with_faces, self.counts[0])
            self._add(part, offset)
            line += block.count(b"\n")
            offset += len(block)

    def _add(self, part: BlockPart, offset: int) -> None:
        """Take in the block read into ``part``, which starts ``offset`` bytes into the file."""
        if part.first_face >= 0 and self.first_face is None:
            self.first_face = (offset + part.first_face, self.counts[0] + int(part.defined[0, 0]))
        if part.corners is not None:
            self._add_faces(part)
        self.digest.update(part.face_text)
        for faces_before, names in part.groups:
            self._close_group(self.face_count + faces_before)
            self.group_names = names
        self.face_count += len(part.face_rows)
        if len(part.vertices):
            self.coordinates.frombytes(part.vertices.tobytes())
        self.counts = [
            self.counts[0] + len(part.vertices),
            self.counts[1] + part.textures,
            self.counts[2] + part.normals,
        ]

    def _add_faces(self, part: BlockPart) -> None:
        """Resolve the block's corners (relative indices against what is defined before each face) and keep
        its vertex indices; a relative index before the list is refused here, one past the end at the end."""
        corners = part.corners
        assert corners is not None
        largest = int(np.argmax(corners.sizes))
        if corners.sizes[largest] > self.furthest[3][0]:
            self.furthest[3] = (int(corners.sizes[largest]), int(part.face_rows[largest]))
        face_of_corner = np.repeat(np.arange(len(corners.sizes)), corners.sizes)
        for kind, written in enumerate(corners.indices):
            before = self.counts[kind] + part.defined[kind][face_of_corner]
            relative = written < 0
            if (relative & (written + before < 0)).any():
                corner = int(np.flatnonzero(relative & (written + before < 0))[0])
                face = int(face_of_corner[corner])
                raise RigError(
                    f"{self.source}:{part.face_rows[face]}: face indexes a {INDEX_KINDS[kind]} outside "
                    f"1..{before[corner]} (relative to those defined before it): "
                    f"{part.face_line(face)[:82]!r}"
                )
            corner = int(np.argmax(written))
            if written[corner] > self.furthest[kind][0]:
                self.furthest[kind] = (int(written[corner]), int(part.face_rows[face_of_corner[corner]]))
            if kind == 0:
                resolved = np.where(relative, written + before, written - 1)
                self.corners.frombytes(resolved.astype(np.int64).tobytes())
        first = int(corners.sizes[0])
        if self.uniform in (0, first) and (corners.sizes == first).all() and not self.sizes:
            self.uniform = first
            return
        if self.uniform:  # (the first polygon of another size: every size is kept from now on)
            self.sizes.frombytes(np.full(self.face_count, self.uniform, dtype=np.int64).tobytes())
            self.uniform = 0
        self.sizes.frombytes(corners.sizes.astype(np.int64).tobytes())

    def _close_group(self, face: int) -> None:
        """The faces up to ``face`` belong to the current groups."""
        if face > self.group_start and self.group_names:
            self.group_runs.append((self.group_start, face, self.group_names))
        self.group_start = face

    def vertices(self) -> np.ndarray:
        """(N, 3) positions of the file's ``v`` lines."""
        if not self.counts[0]:
            raise RigError(f"{self.source}: no vertices ('v' lines)")
        return np.frombuffer(self.coordinates, dtype=np.float64).reshape(-1, 3)

    def mesh(self, data: bytes) -> ObjMesh:
        """The mesh read from ``data`` (once every block is read)."""
        vertices = self.vertices()
        faces = self._polygons(data)
        self._close_group(self.face_count)
        found: dict[str, list[np.ndarray]] = {}
        for start, stop, names in self.group_runs:
            for name in dict.fromkeys(names):  # (a name given twice lists each face twice)
                found.setdefault(name, []).append(np.repeat(np.arange(start, stop), names.count(name)))
        groups = {name: np.concatenate(parts) for name, parts in found.items()}
        layout = None
        if self.first_face is not None and self.first_face[1] == len(vertices) and b"\r" not in data:
            layout = NeutralLayout.of(data, self.first_face[0], len(vertices))
        digest = self.digest.digest() if self.face_count else b""
        return ObjMesh(vertices, faces, groups, digest, layout)

    def _polygons(self, data: bytes) -> Polygons:
        """The polygons, once every index is known to lie in its list (``data``: the file, for messages)."""
        if not self.with_faces or not self.face_count:
            return Polygons.empty()
        corners, line = self.furthest[3]
        if corners > self.counts[0]:  # a polygon repeats a vertex (and would be costly)
            raise RigError(
                f"{self.source}:{line}: face has {corners} corners, more than the mesh's "
                f"{self.counts[0]} vertices"
            )
        for kind in range(3):
            index, line = self.furthest[kind]
            if index > self.counts[kind]:
                where = f"outside 1..{self.counts[kind]}" if self.counts[kind] else "but the file has none"
                raise RigError(
                    f"{self.source}:{line}: face indexes a {INDEX_KINDS[kind]} {where}: "
                    f"{_line_text(data, line)[:82]!r}"
                )
        flat = np.frombuffer(self.corners, dtype=np.int64)
        if self.uniform:  # (one size repeated, not an array of it)
            return Polygons(np.broadcast_to(np.int64(self.uniform), (self.face_count,)), flat)
        return Polygons(np.frombuffer(self.sizes, dtype=np.int64), flat)


def _line_text(data: bytes, number: int) -> str:
    """The text of physical line ``number`` of ``data`` (line ends normalised), for messages."""
    for block in _blocks(data):
        lines = block.split(b"\n")
        if number <= len(lines) - 1:
            return lines[number - 1].decode("utf-8", errors="replace").strip()
        number -= len(lines) - 1
    return ""


def _line_block(block: bytes, line: int, source: str, with_faces: bool, vertices_before: int) -> BlockPart:
    """`rigs._obj_block.line_block` of a block's bytes (UTF-8, undecodable bytes replaced)."""
    return line_block(
        block.decode("utf-8", errors="replace"),
        line,
        source,
        with_faces=with_faces,
        vertices_before=vertices_before,
    )


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
