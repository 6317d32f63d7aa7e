"""The material libraries an OBJ's ``mtllib`` lines name, and the texture maps those name, copied into the
session beside the OBJs that keep the lines, so that the session folder shows the expressions as the rig
showed its neutral wherever it is moved.

Only files inside the OBJ's own folder are read (`rigs._safe`: no link or ``..`` leads out of it), and
each is written at the path the line names, relative to the session's OBJ as it was to the source's.
"""

from __future__ import annotations

import posixpath
import warnings
from collections.abc import Iterator
from pathlib import Path, PurePosixPath
from typing import TYPE_CHECKING

from rigs import RigError, RigWarning, folder_relative, read_bytes

if TYPE_CHECKING:
    from rigs import ObjSurface

#: Words an option takes besides numbers: ``on``/``off`` switches, ``-imfchan``'s channel and ``-type``'s
#: reflection projection (MTL specification).
SWITCH = frozenset({"on", "off"})
CHANNELS = frozenset({"r", "g", "b", "m", "l", "z"})
PROJECTIONS = frozenset(
    {"sphere", "cube_top", "cube_bottom", "cube_front", "cube_back", "cube_left", "cube_right"}
)
#: Options of a map statement: the most arguments each takes and the words it takes (numbers when empty).
MAP_OPTIONS: dict[str, tuple[int, frozenset[str]]] = {
    "-blendu": (1, SWITCH), "-blendv": (1, SWITCH), "-bm": (1, frozenset()), "-boost": (1, frozenset()),
    "-cc": (1, SWITCH), "-clamp": (1, SWITCH), "-imfchan": (1, CHANNELS), "-mm": (2, frozenset()),
    "-o": (3, frozenset()), "-s": (3, frozenset()), "-t": (3, frozenset()), "-texres": (1, frozenset()),
    "-type": (1, PROJECTIONS),
}  # fmt: skip
#: Largest material library or texture map copied (an 8K 16-bit map is 400 MB).
LARGEST_FILE = 1 << 29
#: The ``.mtl`` statements whose last word is a texture map's file name (their options come before it).
MAP_STATEMENTS = frozenset(
    {
        "map_ka", "map_kd", "map_ks", "map_ke", "map_ns", "map_d", "map_bump", "bump", "disp", "decal",
        "refl", "norm", "map_pr", "map_pm", "map_ps", "map_rma", "map_orm",
    }
)  # fmt: skip


def material_files(surface: ObjSurface, obj: Path, folder: Path) -> Iterator[tuple[str, bytes]]:
    """(name relative to the OBJ, content) of every material library the ``mtllib`` lines of ``surface``
    (read from ``obj``) name and every texture map those libraries name, found inside ``folder``.

    A name that is absolute, leads out of the OBJ's folder, or is missing or unreadable there is skipped:
    the OBJ keeps its line, as the source did, and a `rigs.RigWarning` names the file not carried along
    (the copy then points where the source pointed, which is no file beside the session). A map's file name
    may hold spaces (as Blender and Maya write them): the words after the statement's options are its name
    (`_texture_names`).

    Warns
    -----
    RigWarning
        For each library or texture map that is not copied.
    """
    base = obj.parent
    seen: set[str] = set()
    for library in _named(surface.lines, "mtllib"):
        data = _read(base / library, folder)
        if data is None:
            _not_copied(obj, f"material library {library!r}")
        if data is None or library in seen:
            continue
        seen.add(library)
        yield library, data
        text = data.decode("utf-8-sig", errors="replace")
        for number, candidates in _texture_names(text):
            found = _first_found(library, candidates, base, folder)
            if found is None:
                _not_copied(obj, f"texture map {candidates[0]!r} ({library}:{number})")
            elif found[0] not in seen:  # (``../maps/skin.png`` beside ``mtl/face.mtl`` is inside)
                seen.add(found[0])
                yield found


def _first_found(library: str, candidates: list[str], base: Path, folder: Path) -> tuple[str, bytes] | None:
    """The first of the ``candidates`` (names relative to the ``library``, the whole name first) that is a
    readable file inside ``folder``, as its name relative to ``base`` (the OBJ's folder) and its bytes; None
    as soon as a name leads outside the folder (a shorter name would be another file)."""
    for texture in candidates:
        name = folder_relative(posixpath.normpath((PurePosixPath(library).parent / texture).as_posix()))
        if name is None:
            return None
        image = _read(base / name, folder)
        if image is not None:
            return name, image
    return None


def _not_copied(obj: Path, what: str) -> None:
    warnings.warn(
        f"{obj}: {what} is not a readable file inside the rig's folder and is not copied into the "
        "session; the session's files name it as the rig's did",
        RigWarning,
        stacklevel=4,
    )


def _named(lines: tuple[str, ...], keyword: str) -> Iterator[str]:
    """The file names of the ``keyword`` lines, each a clean relative path."""
    for line in lines:
        words = line.split()
        if words[:1] == [keyword]:
            for word in words[1:]:
                name = folder_relative(word)
                if name is not None:
                    yield name


def _texture_names(text: str) -> Iterator[tuple[int, list[str]]]:
    """Per map statement of a material library, its line number and its file's name: the words after its
    options (`MAP_OPTIONS`, each with the arguments of its kind), joined by spaces (a name may hold them),
    without quotes; the last word too when that differs, for a name written after an unknown option."""
    for number, line in enumerate(text.splitlines(), start=1):
        words = line.split("#", 1)[0].split()
        if len(words) < 2 or words[0].lower() not in MAP_STATEMENTS:
            continue
        rest = words[1:]
        while rest and rest[0].lower() in MAP_OPTIONS:
            most, takes = MAP_OPTIONS[rest[0].lower()]
            rest = rest[1:]
            for _ in range(most):
                argument = rest[0].lower() if len(rest) > 1 else None
                if argument is not None and (argument in takes if takes else _is_number(argument)):
                    rest = rest[1:]
        names = [" ".join(rest), rest[-1]] if len(rest) > 1 else rest
        if names:
            yield number, [name.strip("\"'").replace("\\", "/") for name in names]


def _is_number(word: str) -> bool:
    try:
        float(word)
    except ValueError:
        return False
    return True


def _read(path: Path, folder: Path) -> bytes | None:
    """The file's bytes when it is a regular file inside ``folder`` of at most `LARGEST_FILE`, else None."""
    try:
        return read_bytes(path, root=folder, limit=LARGEST_FILE, why="a copied material file")
    except (RigError, OSError):
        return None
