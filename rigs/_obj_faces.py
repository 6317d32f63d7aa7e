"""OBJ face lines to polygons: the corners of ``f`` lines (vertex, texture and normal indices) read in one
go with numpy from a plain block of face lines, or line by line to name the line at fault; polygons kept as
one array of corners (`Polygons`)."""

from __future__ import annotations

import re
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from rigs._rig import RigError

#: An index in a face corner: ASCII digits with an optional sign.
_INDEX = re.compile(r"[+-]?[0-9]+")
_SPACE, _LINE_FEED, _SLASH = ord(" "), ord("\n"), ord("/")
#: Digits of the longest index `plain_corners` reads (longer ones are left to `face_corners`).
_INDEX_DIGITS = 18
#: An index beyond any list a file can hold, to which larger ones are clipped before they are resolved.
_FAR = 2**62
#: The kinds of index a corner holds (``v/vt/vn``), as named in messages.
INDEX_KINDS = ("vertex", "texture coordinate", "normal")


@dataclass(frozen=True, eq=False)
class Polygons(Sequence[np.ndarray]):
    """Polygons as one array of corners: polygon ``i`` is the next ``sizes[i]`` entries of ``corners``.

    A sequence of int arrays (one per polygon, views into ``corners``), held without an array object per
    polygon: a mesh of millions of faces costs its indices, not millions of Python objects.

    Attributes
    ----------
    sizes : (F,) int64 array
        Corners of each polygon (a read-only broadcast of one size when all have as many).
    corners : (sum(sizes),) int64 array
        0-based vertex indices, polygon after polygon.
    """

    sizes: np.ndarray
    corners: np.ndarray

    @classmethod
    def of(cls, faces: Sequence[np.ndarray]) -> Polygons:
        """``faces`` (any sequence of index arrays) as `Polygons`."""
        if isinstance(faces, Polygons):
            return faces
        sizes = np.fromiter((len(face) for face in faces), dtype=np.int64, count=len(faces))
        arrays = [np.asarray(face, dtype=np.int64).ravel() for face in faces]
        return cls(sizes, np.concatenate(arrays) if arrays else np.zeros(0, dtype=np.int64))

    @classmethod
    def empty(cls) -> Polygons:
        return cls(np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64))

    @cached_property
    def starts(self) -> np.ndarray:
        """(F + 1,) offset of each polygon's first corner in `corners`, and the total."""
        return np.concatenate([[0], np.cumsum(self.sizes, dtype=np.int64)])

    @property
    def size(self) -> int | None:
        """The corners of every polygon when all have as many, else None."""
        if not len(self.sizes):
            return None
        first = int(self.sizes[0])
        return first if (self.sizes == first).all() else None

    def __len__(self) -> int:
        return len(self.sizes)

    def __getitem__(self, index: int) -> np.ndarray:  # type: ignore[override]
        index = range(len(self))[index]
        return self.corners[self.starts[index] : self.starts[index + 1]]

    def __iter__(self) -> Iterator[np.ndarray]:
        size = self.size
        if size is not None:
            return iter(self.corners.reshape(-1, size))
        return iter(np.split(self.corners, self.starts[1:-1]))


def first_difference(mine: Polygons, theirs: Polygons) -> int | None:
    """The first polygon at which two lists of as many polygons differ, or None when they are equal."""
    differs = mine.sizes != theirs.sizes
    if not differs.any() and np.array_equal(mine.corners, theirs.corners):
        return None
    if not differs.any():
        corner = int(np.flatnonzero(mine.corners != theirs.corners)[0])
        return int(np.searchsorted(mine.starts, corner, side="right") - 1)
    first = int(np.flatnonzero(differs)[0])
    same = np.flatnonzero(mine.corners[: mine.starts[first]] != theirs.corners[: theirs.starts[first]])
    return int(np.searchsorted(mine.starts, same[0], side="right") - 1) if len(same) else first


@dataclass(frozen=True)
class Corners:
    """The corners of a block of face lines as written: corners per line, and each corner's vertex,
    texture and normal index (1-based or negative; 0 where the corner gives none, which only the texture
    and normal indices may do)."""

    sizes: np.ndarray
    indices: tuple[np.ndarray, np.ndarray, np.ndarray]


def _integers(data: np.ndarray, starts: np.ndarray, stops: np.ndarray) -> np.ndarray | None:
    """The signed decimal integers ``data[starts:stops]`` (0 for an empty span), or None when one is not
    one (or has more than 18 digits); read right-aligned, one digit place of every span at a time."""
    signed = (stops > starts) & ((data[starts] == ord("-")) | (data[starts] == ord("+")))
    first = starts + signed
    width = int((stops - first).max(initial=0))
    if (signed & (stops <= first)).any() or width > _INDEX_DIGITS:
        return None
    values = np.zeros(len(starts), dtype=np.int64)
    for place in range(width):
        at = stops - width + place
        digits = data[np.maximum(at, 0)] - np.uint8(ord("0"))  # (past 9 for any other byte)
        digits[at < first] = 0
        if (digits > 9).any():
            return None
        values = values * 10 + digits
    return np.where(signed & (data[starts] == ord("-")), -values, values)


def plain_corners(block: bytes) -> Corners | None:
    """The corners of the face lines of a plain block (``block``: its ``f`` lines, each ending in a line
    feed), read with numpy; None for a comment, a face of fewer than 3 corners, a corner that is not
    ``v``, ``v/vt``, ``v/vt/vn`` or ``v//vn`` of plain integers of up to 18 digits, or an index written
    as 0 (left to `face_corners`, which names the line)."""
    if b"#" in block or not block:
        return None
    data = np.frombuffer(block, dtype=np.uint8)
    separator = (data == _SPACE) | (data == _LINE_FEED)
    after_separator = np.concatenate([[True], separator[:-1]])
    starts = np.flatnonzero(~separator & after_separator)
    keyword = after_separator[starts] & np.concatenate([[True], data[:-1] == _LINE_FEED])[starts]
    keywords = np.flatnonzero(keyword)
    sizes = np.diff(np.append(keywords, len(keyword))) - 1
    if not len(sizes) or sizes.min() < 3:
        return None
    ends = np.flatnonzero(~separator & np.concatenate([separator[1:], [True]]))[~keyword] + 1
    starts = starts[~keyword]
    vertex = _integers(data, starts, ends) if b"/" not in block else None
    if vertex is not None:
        none = np.zeros(len(starts), dtype=np.int64)
        return Corners(sizes, (vertex, none, none)) if (vertex != 0).all() else None
    slashes = np.flatnonzero(data == _SLASH)
    following = np.append(slashes, len(data))
    passed = np.searchsorted(slashes, starts)
    count = np.searchsorted(slashes, ends) - passed
    if count.max() > 2:
        return None  # a third slash
    first = np.where(count >= 1, following[passed], ends)
    second = np.where(count >= 2, following[np.minimum(passed + 1, len(following) - 1)], ends)
    if ((count == 1) & (first + 1 == ends)).any():  # 'v/' with nothing after the slash
        return None
    fields = [
        _integers(data, starts, first),
        _integers(data, np.minimum(first + 1, ends), second),
        _integers(data, np.minimum(second + 1, ends), ends),
    ]
    if any(field is None for field in fields):
        return None
    spans = [first - starts, second - first - 1, ends - second - 1]
    if (spans[0] < 1).any() or any(
        ((field == 0) & (span > 0)).any() for field, span in zip(fields, spans, strict=True)
    ):
        return None  # (a missing vertex index, or an index written as 0)
    return Corners(sizes, (fields[0], fields[1], fields[2]))  # type: ignore[arg-type]


def face_corners(lines: Sequence[str], line_numbers: Sequence[int], source: str) -> Corners:
    """The corners of face lines (what follows each ``f``), one line at a time.

    Raises
    ------
    RigError
        For a face of fewer than 3 corners, a corner that is not ``v``, ``v/vt``, ``v/vt/vn`` or
        ``v//vn`` of integers (an index written as 0 or past 64 bits is read as 2**62, outside any list, and
        refused when resolved).
    """
    canonical = "".join(f"f {' '.join(line.split())}\n" for line in lines)
    corners = plain_corners(canonical.encode()) if canonical.isascii() else None
    if corners is not None:  # (every line at once; a line at fault is found one at a time below)
        return corners
    sizes = np.fromiter(map(len, map(str.split, lines)), dtype=np.int64, count=len(lines))
    columns: tuple[list[int], list[int], list[int]] = ([], [], [])
    for i, line in enumerate(lines):
        tokens = line.split()
        if len(tokens) < 3:
            raise RigError(f"{source}:{line_numbers[i]}: face needs at least 3 corners, got 'f {line[:80]}'")
        for token in tokens:
            fields = token.split("/")
            if len(fields) > 3 or fields[1:] == [""]:
                raise RigError(f"{source}:{line_numbers[i]}: face has a malformed corner: 'f {line[:80]}'")
            fields += [""] * (3 - len(fields))
            for kind, (column, field) in enumerate(zip(columns, fields, strict=True)):
                try:
                    if (field or not kind) and not _INDEX.fullmatch(field):
                        raise ValueError(field)
                    value = int(field) if field else 0
                except ValueError:  # (also past Python's 4300 digits)
                    raise RigError(
                        f"{source}:{line_numbers[i]}: face has a malformed {INDEX_KINDS[kind]} index: "
                        f"'f {line[:80]}'"
                    ) from None
                if field and value == 0:  # (outside any list: refused when resolved)
                    value = _FAR
                # (an index past any list is clipped, and refused when resolved)
                column.append(value if -_FAR <= value <= _FAR else _FAR if value > 0 else -_FAR)
    return Corners(sizes, tuple(np.asarray(column, dtype=np.int64) for column in columns))  # type: ignore[arg-type]
