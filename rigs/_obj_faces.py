"""OBJ face lines to polygons: corner counts and vertex indices read in one go with numpy from a plain
file's face lines, or from any face lines split in one go, else line by line to name the line at fault;
negative (relative) indices resolved; every index checked against the mesh."""

from __future__ import annotations

import re
from array import array
from collections.abc import Sequence

import numpy as np

from rigs._rig import RigError

#: A vertex index in a face corner: ASCII digits with an optional sign.
_INDEX = re.compile(r"[+-]?[0-9]+")
#: What follows the vertex index in a face corner (``/vt/vn``), up to the next whitespace.
_CORNER_REST = re.compile(r"/\S*")
_SPACE, _LINE_FEED = ord(" "), ord("\n")


def faces_of_lines(
    lines: list[str],
    line_numbers: Sequence[int],
    vertex_counts: Sequence[int],
    n_vertices: int,
    source: str,
    corners: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, ...]:
    """0-based polygons of face lines; ``vertex_counts`` are the vertices defined before each line (for
    negative indices); ``corners``: their corner counts and indices as written when already read
    (`plain_corners`). Raises `RigError` for the first line at fault."""
    counts, flat = corners if corners is not None else _face_corners(lines, line_numbers, n_vertices, source)
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
    if (counts == counts[0]).all():  # (one polygon size: rows of one array)
        return tuple(flat.reshape(-1, int(counts[0])))
    ends = np.cumsum(counts).tolist()
    return tuple(flat[start:end] for start, end in zip([0, *ends[:-1]], ends, strict=True))


#: Digits of the longest vertex index `plain_corners` reads (longer ones are left to `_face_corners`).
_INDEX_DIGITS = 18


def plain_corners(block: bytes) -> tuple[np.ndarray, np.ndarray] | None:
    """Corner counts and vertex indices as written of the face lines of a plain file (``block``: its
    ``f`` lines, each ending in a line feed), read with numpy; None for a comment, a face of fewer than
    3 corners, or a corner whose vertex index is not a plain integer of up to 18 digits (left to
    `_face_corners`, which names the line)."""
    if b"#" in block:
        return None
    data = np.frombuffer(block, dtype=np.uint8)
    separator = (data == _SPACE) | (data == _LINE_FEED)
    after_separator = np.concatenate([[True], separator[:-1]])
    starts = np.flatnonzero(~separator & after_separator)
    keyword = after_separator[starts] & np.concatenate([[True], data[:-1] == _LINE_FEED])[starts]
    line_of_token = np.cumsum(keyword) - 1
    counts = np.bincount(line_of_token, minlength=int(keyword.sum())) - 1
    if not len(counts) or counts.min() < 3:
        return None
    starts = starts[~keyword]
    ends = np.flatnonzero(~separator & np.concatenate([separator[1:], [True]]))[~keyword] + 1
    slashes = np.flatnonzero(data == ord("/"))
    next_slash = np.append(slashes, len(data))[np.searchsorted(slashes, starts)]
    stops = np.minimum(ends, next_slash)
    signed = (data[starts] == ord("-")) | (data[starts] == ord("+"))
    first = starts + signed
    lengths = stops - first
    if lengths.min() < 1 or lengths.max() > _INDEX_DIGITS:
        return None
    values = np.zeros(len(starts), dtype=np.int64)
    for place in range(int(lengths.max())):
        inside = lengths > place
        digit = data[np.where(inside, first + place, 0)].astype(np.int64) - ord("0")
        if ((digit < 0) | (digit > 9))[inside].any():
            return None
        values = np.where(inside, values * 10 + digit, values)
    return counts, np.where(data[starts] == ord("-"), -values, values)


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
    plain = joined.isascii() and "_" not in joined  # (int() reads '1_0' and non-ASCII digits)
    if plain and len(words) == counts.sum() and counts.min() >= 3:
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
            indices = [token.partition("/")[0] for token in tokens]
            if not all(_INDEX.fullmatch(index) for index in indices):
                raise ValueError(indices)
            corners.extend([int(index) for index in indices])
        except ValueError:
            raise RigError(
                f"{source}:{line_numbers[i]}: face has a malformed vertex index: 'f {line[:80]}'"
            ) from None
        except OverflowError:  # an index past 64 bits
            raise RigError(
                f"{source}:{line_numbers[i]}: face indexes a vertex outside 1..{n_vertices}: 'f {line[:80]}'"
            ) from None
    return counts, np.frombuffer(corners, dtype=np.int64)
