"""An OBJ's own text around new positions: everything a file says besides its vertex positions, kept to
write the same mesh (texture coordinates, normals, groups, materials) at the positions of an expression."""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from rigs._arrow_lines import vertex_lines
from rigs._obj import numbered_lines, parse_obj
from rigs._obj_folder import polygon_lines
from rigs._rig import Rig, RigError, RigWarning
from rigs._safe import UnreadableFile, folder_relative, read_text


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
    lines = [line for _, line in numbered_lines(text)]
    if lines and lines[-1] == "":
        lines.pop()
    rows, tails = [], []
    for index, line in enumerate(lines):
        if line[:6] == "mtllib":
            _check_libraries(line, f"{source}:{index + 1}")
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


def _check_libraries(line: str, where: str) -> None:
    """Warn of a material library of the ``mtllib`` ``line`` that lies outside the OBJ's folder (an absolute
    path or one that climbs out): the files written from the surface keep the reference as written, and an
    application opening them would read that file."""
    for name in line.split()[1:]:
        if folder_relative(name) is None:
            warnings.warn(
                f"{where}: material library {name!r} lies outside the OBJ's folder; files written from it "
                "keep the reference as written",
                RigWarning,
                stacklevel=4,
            )


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

    The rig's `rigs.Surface` names it (``surface.obj``): a rig read from a folder of OBJs has its neutral
    OBJ, the Face Units rig its cropped base mesh. The file must have the rig's vertex count and its
    positions must be the rig's neutral (up to the file's rounding), so that writing the rig's positions
    into it keeps every other line right.
    """
    if rig.surface is None or rig.surface.obj is None:
        return None
    path, root = rig.surface.obj, rig.surface.folder
    if not path.is_file():
        return None
    surface = read_surface(path, root=root)
    if surface.n_vertices != rig.n_vertices:
        return None
    vertex_text = "\n".join(surface.lines[i] for i in surface.vertex_rows)
    positions = parse_obj(vertex_text, str(path), with_faces=False).vertices  # (raises, naming the line)
    tolerance = max(rig.provenance.decimal_step, 1e-6 * rig.diagonal())
    return surface if np.abs(positions - rig.neutral).max() <= tolerance else None


def plain_surface(rig: Rig) -> ObjSurface:
    """The `ObjSurface` of what a rig itself holds: its vertices and its polygons (``rig.faces``, else the
    triangles), for rigs that do not come from an OBJ."""
    faces = rig.faces if rig.faces is not None else rig.triangles
    lines = ["v 0 0 0"] * rig.n_vertices + polygon_lines(faces).decode("ascii").splitlines()
    source = rig.provenance.label
    return ObjSurface(tuple(lines), np.arange(rig.n_vertices), ("",) * rig.n_vertices, source)
