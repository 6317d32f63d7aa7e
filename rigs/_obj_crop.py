"""Cropping an OBJ to part of its mesh, every other line kept as written."""

from __future__ import annotations

import numpy as np

from rigs._obj import numbered_lines
from rigs._rig import RigError


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
    lines = [line for _, line in numbered_lines(text.replace("\r\n", "\n").replace("\r", "\n"))]
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
