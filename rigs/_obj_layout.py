"""Blendshape OBJ files that repeat their neutral's text around other vertex lines.

An exporter writes each blendshape of a rig as its neutral's file with other positions: the same header,
texture coordinates, normals and faces, byte for byte (a few also write their own header line or normals).
`NeutralLayout` keeps where the neutral's text holds its run of ``v`` lines and its face section, so that a
blendshape file is checked against the neutral's bytes (a memory comparison) and only its ``v`` lines are
read, in one call to Arrow (`rigs._obj_block.plain_vertex_block`). Whatever does not fit is left to the
reader of whole files (`rigs._obj.parse_obj`), which reads it as before and names the line at fault.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rigs._obj_block import is_continued, is_plain, line_block, plain_block, plain_vertex_block
from rigs._rig import RigError

#: How a ``v x y z`` line starts (a line of a file that holds no ``\\`` line continuation).
_VERTEX_LINE = b"v "


@dataclass(frozen=True, eq=False)
class NeutralLayout:
    """Where a neutral OBJ's text holds its vertex lines and its face section.

    Attributes
    ----------
    data : bytes
        The neutral's file (its lines end in line feeds).
    face_start : int
        Where its first ``f`` line starts (every ``v`` line comes before it).
    run : (int, int) or None
        Where its vertex lines start and stop when they are one run of ``v ...`` lines, one per vertex, and
        no line before the face section is continued with ``\\``; else None (blendshape files are then
        recognised by the face section alone).
    """

    data: bytes
    face_start: int
    run: tuple[int, int] | None

    @classmethod
    def of(cls, data: bytes, face_start: int, vertex_count: int) -> NeutralLayout:
        """The layout of a neutral's ``data`` whose face section starts at ``face_start``, after all of its
        ``vertex_count`` vertices."""
        run = None if data.find(b"\\", 0, face_start) >= 0 else _vertex_run(data, face_start)
        if run is not None:
            start, stop = run
            lines = data.count(b"\n", start, stop)
            if lines != vertex_count or 1 + data.count(b"\n" + _VERTEX_LINE, start, stop) != lines:
                run = None
        return cls(data, face_start, run)

    def faces_at(self, data: bytes) -> int | None:
        """Where the neutral's face section starts in ``data`` when ``data`` ends with it, after a line end
        that does not continue its line; else None."""
        faces = memoryview(self.data)[self.face_start :]
        stop = len(data) - len(faces)
        if stop <= 0 or not data.endswith(faces) or data[stop - 1] != ord("\n"):
            return None
        if is_continued(data, stop - 1):
            return None
        return stop

    def shape_vertices(self, data: bytes, face_start: int, source: str) -> np.ndarray | None:
        """The positions of a blendshape file ``data`` that ends with the neutral's face section (at
        ``face_start``: `faces_at`), when its text before that is a run of plain ``v x y z`` lines with
        finite coordinates (`plain_vertex_block`) between two parts that hold no vertex and no face: the
        neutral's own (compared byte for byte), or text read to hold none; else None.

        ``source`` names the file in the messages of the reading of those parts (a part that would raise
        gives None: the reader of whole files raises, naming the line).
        """
        start = _run_start(data, face_start)
        if self.run is None or start is None:
            return None
        neutral_start, neutral_stop = self.run
        between = memoryview(self.data)[neutral_stop : self.face_start]
        stop = face_start - len(between)
        if not (start < stop and data[stop - 1] == ord("\n") and data.startswith(between, stop)):
            stop = _run_stop(data, start, face_start)
            if not self._holds_nothing(data, stop, face_start, neutral_stop, self.face_start, source):
                return None
        if not self._holds_nothing(data, 0, start, 0, neutral_start, source):
            return None
        block = data[start:stop]
        return plain_vertex_block(block) if is_plain(block) and b"\r" not in block else None

    def _holds_nothing(
        self, data: bytes, start: int, stop: int, neutral_start: int, neutral_stop: int, source: str
    ) -> bool:
        """Whether ``data[start:stop]`` is the neutral's ``[neutral_start:neutral_stop]``, or lines of their
        own (without continuations or carriage returns) that define no vertex and no face."""
        neutral = memoryview(self.data)[neutral_start:neutral_stop]
        if stop - start == len(neutral) and data.startswith(neutral, start):
            return True
        part = data[start:stop]
        if not part:
            return True
        if b"\r" in part or b"\\" in part:
            return False
        try:
            read = plain_block(part, 1, source, with_faces=False) if is_plain(part) else None
            if read is None:
                text = part.decode("utf-8", errors="replace")
                read = line_block(text, 1, source, with_faces=False, vertices_before=0)
        except RigError:
            return False
        return not len(read.vertices) and not len(read.face_rows)


def _vertex_run(data: bytes, face_start: int) -> tuple[int, int] | None:
    """Where the lines before ``face_start`` from the first ``v ...`` line to the last one start and stop,
    or None without such a line."""
    start = _run_start(data, face_start)
    return None if start is None else (start, _run_stop(data, start, face_start))


def _run_start(data: bytes, face_start: int) -> int | None:
    """Where the first line before ``face_start`` that starts with ``v `` starts, or None."""
    if data.startswith(_VERTEX_LINE):
        return 0
    start = data.find(b"\n" + _VERTEX_LINE, 0, face_start) + 1
    return start or None


def _run_stop(data: bytes, start: int, face_start: int) -> int:
    """Past the line feed of the last line from ``start`` to ``face_start`` (a line end) that starts with
    ``v ``."""
    last = data.rfind(b"\n" + _VERTEX_LINE, start, face_start) + 1 or start
    return data.find(b"\n", last, face_start) + 1
