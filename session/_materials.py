"""The material libraries an OBJ's ``mtllib`` lines name, and the texture maps those name, copied into the
session beside the OBJs that keep the lines, so that the session folder shows the expressions as the rig
showed its neutral wherever it is moved.

Only files inside the OBJ's own folder are read (`rigs._safe`: no link or ``..`` leads out of it), and
each is written at the path the line names, relative to the session's OBJ as it was to the source's.
"""

from __future__ import annotations

import posixpath
from collections.abc import Iterator
from pathlib import Path, PurePosixPath
from typing import TYPE_CHECKING

from rigs import RigError, folder_relative, read_bytes

if TYPE_CHECKING:
    from rigs import ObjSurface

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
    the OBJ keeps its line, as the source did.
    """
    base = obj.parent
    seen: set[str] = set()
    for library in _named(surface.lines, "mtllib"):
        data = _read(base / library, folder)
        if data is None or library in seen:
            continue
        seen.add(library)
        yield library, data
        text = data.decode("utf-8-sig", errors="replace")
        for texture in _texture_names(text):
            name = folder_relative(posixpath.normpath((PurePosixPath(library).parent / texture).as_posix()))
            if name is None or name in seen:  # (``../maps/skin.png`` beside ``mtl/face.mtl`` is inside)
                continue
            image = _read(base / name, folder)
            if image is not None:
                seen.add(name)
                yield name, image


def _named(lines: tuple[str, ...], keyword: str) -> Iterator[str]:
    """The file names of the ``keyword`` lines, each a clean relative path."""
    for line in lines:
        words = line.split()
        if words[:1] == [keyword]:
            for word in words[1:]:
                name = folder_relative(word)
                if name is not None:
                    yield name


def _texture_names(text: str) -> Iterator[str]:
    """The texture maps of a material library: the last word of each map statement."""
    for line in text.splitlines():
        words = line.split("#", 1)[0].split()
        if len(words) >= 2 and words[0].lower() in MAP_STATEMENTS:
            yield words[-1].replace("\\", "/")


def _read(path: Path, folder: Path) -> bytes | None:
    """The file's bytes when it is a regular file inside ``folder`` of at most `LARGEST_FILE`, else None."""
    try:
        return read_bytes(path, root=folder, limit=LARGEST_FILE, why="a copied material file")
    except (RigError, OSError):
        return None
