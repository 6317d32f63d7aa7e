"""Rigs as folders of Wavefront OBJ files: finding the neutral and the blendshapes, reading, writing.

A rig folder holds the neutral mesh (``neutral.obj`` unless told otherwise) and one OBJ per blendshape with
the same vertices and faces, beside it or, as many exporters write them, in one subfolder (``shapes/``);
the blendshape's name is its file stem. The folder may also hold ``rig.json``
(written by :func:`save_obj_folder`) that fixes the shape order and keeps regions and units.
"""

from __future__ import annotations

import json
import os
import re
import warnings
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path

import numpy as np

from registry import atomic_write
from rigs._arrow_lines import triangle_lines, vertex_lines
from rigs._obj import ObjMesh, decimal_step, read_obj
from rigs._obj_faces import first_difference
from rigs._provenance import Provenance, Surface
from rigs._rig import Rig, RigError, RigWarning
from rigs._safe import UnreadableFile, check_budget, named_path, read_text, regular_file, rig_entries
from rigs._triangulate import faces_are_triangles, triangulate
from rigs._vertex_order import VertexOrder

MANIFEST = "rig.json"
#: Largest ``rig.json`` read (regions of a dense mesh take a few MiB).
MANIFEST_LIMIT = 64 * 2**20
#: Stems (any case) taken for the neutral mesh when the folder has no ``neutral.obj``: exporters and
#: artists also call it the basis (Blender's shape-key basis), base or rest shape.
NEUTRAL_STEMS = ("neutral", "basis", "base", "rest")
_UNSAFE_NAME = re.compile(r'[\\/:*?"<>|\x00-\x1f]')
#: Blendshape files read at once by `load_obj_folder`.


def load_obj_folder(folder: str | Path, *, neutral: str | Path | None = None) -> Rig:
    """A rig from a folder of OBJ files: the neutral plus one OBJ per blendshape (absolute positions).

    Parameters
    ----------
    folder : path
        The folder. Without ``rig.json``, every ``*.obj`` other than the neutral is a blendshape, named by
        its file stem, in sorted order; when the neutral is the only OBJ there, the OBJs of the one
        subfolder that holds any are (shapes beside the neutral and OBJs in a subfolder too are refused:
        which are the shapes?). With ``rig.json`` (see :func:`save_obj_folder`), its ``shapes`` list
        gives the order and its ``regions`` and ``units`` are kept.
    neutral : str or path, optional
        File name (in the folder) or path of the neutral mesh; default ``neutral.obj``, else the one file
        whose stem is, in any case, one of `NEUTRAL_STEMS` (``Neutral.obj``, ``Basis.obj``, ...).

    Returns
    -------
    Rig with ``deltas[k] = shape_k - neutral`` (Carrigan et al. 2020, sec. 3), the polygons kept in
    ``faces`` when any is not a triangle, the neutral OBJ as its ``surface``, and a ``provenance`` with the
    ``source``, ``format = "obj-folder"``, the ``units`` from ``rig.json`` or ``"unknown"`` (OBJ does not
    say), and the ``decimal_step``, the coarsest rounding step of the files' coordinates (`decimal_step`;
    0 when they are not written with a fixed number of decimals), which the noise floor respects.

    Raises
    ------
    RigError
        One line naming the file and the problem: missing folder or neutral, no blendshape files, a
        blendshape whose vertex count or faces differ from the neutral's (the first such file), or whose
        vertices are clearly in another order (`rigs._vertex_order.VertexOrder`), two files with one stem,
        two names equal up to case (``jawOpen``, ``JawOpen``), blendshapes both beside the neutral and in
        a subfolder, a malformed line (a number not in ASCII decimal notation), a non-finite coordinate;
        an ``*.obj`` entry that is not a regular file inside the folder (a FIFO, a device, a dangling or
        looping link, a link outside: see :func:`rigs._safe.rig_entries`); a ``rig.json`` that is not
        JSON, has fields of the wrong type, or names files outside the folder.

    Warns
    -----
    RigWarning
        For ``*.obj`` files that ``rig.json`` does not list (left out), and for a blendshape that looks
        doubtful (`rigs._vertex_order.VertexOrder`: edges rescaled wholesale, most vertices moved far).
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise RigError(f"{folder}: no such folder of OBJ files")
    manifest = _read_manifest(folder)
    entries = rig_entries(folder, _is_obj_name, recursive=False)
    neutral_path = _neutral_path(folder, entries, neutral, manifest.get("neutral"))
    shape_paths = _shape_paths(folder, entries, neutral_path, manifest.get("shapes"))
    if "shapes" not in manifest:  # (a rig.json may list none, as written)
        holding = _subfolders_with_objs(folder)
        if shape_paths and holding:
            raise RigError(
                f"{folder}: blendshapes sit beside the neutral {neutral_path.name} and the subfolder "
                f"{', '.join(sub.name for sub in holding)} also holds OBJ files; keep the blendshapes in one "
                f"place, or list them in {MANIFEST}"
            )
        if not shape_paths:
            shape_paths = _subfolder_shape_paths(folder, neutral_path, holding)

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
    edges = VertexOrder(base.vertices, triangles, neutral_path)
    deltas = np.empty((len(shape_paths), n_vertices, 3))
    step = decimal_step(base.vertices)
    for k, (path, shape) in enumerate(_read_shapes(shape_paths.values(), base, folder)):
        _check_same_mesh(base, shape, path, neutral_path)
        edges.check(shape.vertices, path)
        np.subtract(shape.vertices, base.vertices, out=deltas[k])
        step = max(step, decimal_step(shape.vertices))

    provenance = Provenance(
        source=str(folder), format="obj-folder", units=manifest.get("units", "unknown"), decimal_step=step
    )
    return Rig(
        neutral=base.vertices,
        deltas=deltas,
        triangles=triangles,
        names=tuple(shape_paths),
        regions=dict(manifest.get("regions", {})),
        faces=None if faces_are_triangles(base.faces) else base.faces,
        provenance=provenance,
        surface=Surface(obj=neutral_path, folder=None if outside else folder),
    )


def _read_shapes(paths: Iterable[Path], base: ObjMesh, folder: Path) -> Iterator[tuple[Path, ObjMesh]]:
    """Each blendshape OBJ of ``paths`` read against the neutral ``base``, in order (the first bad file in
    order is the one named).

    One file at a time: reading files in threads cost a third more CPU for a tenth less wall time on two
    cores (a 57-file, 26.7k-vertex export), as parsing holds the interpreter lock for much of a file.
    """
    for path in paths:
        yield path, read_obj(path, with_faces=False, faces_of=base, root=folder)


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
    if "" in manifest.get("regions", {}):
        raise RigError(f"{path}: a region has an empty name")
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


def _subfolders_with_objs(folder: Path) -> dict[Path, list[Path]]:
    """The OBJ files of each subfolder of ``folder`` that holds any (hidden subfolders and links left
    out)."""
    with os.scandir(folder) as found:
        subfolders = sorted(
            Path(entry.path)
            for entry in found
            if entry.is_dir(follow_symlinks=False) and entry.name[:1] != "."
        )
    holding = {sub: rig_entries(sub, _is_obj_name, recursive=False) for sub in subfolders}
    return {sub: entries for sub, entries in holding.items() if entries}


def _subfolder_shape_paths(
    folder: Path, neutral_path: Path, holding: dict[Path, list[Path]]
) -> dict[str, Path]:
    """The blendshapes of an export that puts the neutral at the top and the shapes in one subfolder
    (``shapes/``, ``blendshapes/``, ``targets/``, ...): that subfolder's OBJs (``holding``: those of
    each subfolder), named by their stems.

    Raises
    ------
    RigError
        When no subfolder, or more than one, holds OBJ files.
    """
    if len(holding) != 1:
        linked = sorted(path.name for path in folder.iterdir() if path.is_symlink() and path.is_dir())
        where = (
            f"its subfolders {', '.join(sub.name for sub in holding)} all hold OBJ files; give the shapes "
            "in one folder"
            if holding
            else "its folder has no other OBJ files and no subfolder of them"
            + (f" (symbolic links are not followed: {', '.join(linked)})" if linked else "")
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
        _check_case(list(paths), str(folder))
        return paths
    origin = folder / MANIFEST
    names: dict[str, None] = {}
    for name in listed:
        if not isinstance(name, str) or not name:
            raise RigError(f"{origin}: blendshape names must be non-empty strings, got {name!r:.60}")
        if name in names:
            raise RigError(f"{origin}: duplicate blendshape name {name!r}")
        names[name] = None
    _check_case(list(names), str(origin))
    paths = {}
    for name in names:
        paths[name] = named_path(folder, f"{name}.obj", str(origin))
        if not os.path.lexists(paths[name]):  # (at once: a list of a million names stops at the first)
            raise RigError(f"{paths[name]}: blendshape listed in {MANIFEST} but the file is missing")
    chosen = {os.path.realpath(path) for path in paths.values()} | {neutral_real}
    unlisted = [path.name for path in entries if os.path.realpath(path) not in chosen]
    if unlisted:
        shown = ", ".join(unlisted[:5]) + (f" and {len(unlisted) - 5} more" if len(unlisted) > 5 else "")
        warnings.warn(
            f"{folder}: {shown} not listed in {MANIFEST}'s shapes; left out", RigWarning, stacklevel=4
        )
    return paths


def _check_case(names: list[str], where: str) -> None:
    """Refuse blendshape names equal up to case (``jawOpen``, ``JawOpen``): one file on the file systems
    of Windows and macOS, and a name a TD cannot tell apart in a session."""
    folded: dict[str, str] = {}
    for name in names:
        other = folded.setdefault(name.casefold(), name)
        if other != name:
            raise RigError(
                f"{where}: blendshape names {other!r} and {name!r} differ only in case; rename one"
            )


def _check_same_mesh(base: ObjMesh, shape: ObjMesh, path: Path, neutral_path: Path) -> None:
    if len(shape.vertices) != len(base.vertices):
        expected = len(base.vertices)
        raise RigError(
            f"{path}: {len(shape.vertices)} vertices, but the neutral {neutral_path.name} has {expected}"
        )
    if shape.face_digest in (b"", base.face_digest):  # (a shape file may leave the faces out)
        return
    faces = read_obj(path, root=neutral_path.parent).faces
    if len(faces) != len(base.faces):
        raise RigError(
            f"{path}: {len(faces)} faces, but the neutral {neutral_path.name} has {len(base.faces)}"
        )
    index = first_difference(faces, base.faces)
    if index is not None:
        raise RigError(
            f"{path}: connectivity differs from the neutral {neutral_path.name} at face {index} "
            f"({(faces[index] + 1).tolist()} vs {(base.faces[index] + 1).tolist()})"
        )


def polygon_lines(faces: np.ndarray | Sequence[np.ndarray]) -> bytes:
    """``f`` lines (1-based, ASCII) of a (T, 3) array of triangles or of a sequence of polygons."""
    if isinstance(faces, np.ndarray) or faces_are_triangles(faces):
        return triangle_lines(np.asarray(faces, dtype=np.int64).reshape(-1, 3))
    return "".join("f " + " ".join(map(str, (face + 1).tolist())) + "\n" for face in faces).encode("ascii")


def write_obj(
    path: str | Path, vertices: np.ndarray, faces: Sequence[np.ndarray], *, comment: str = ""
) -> None:
    """Write one OBJ: ``v`` lines with shortest round-trip floats, then 1-based ``f`` lines."""
    header = "".join(f"# {line}\n" for line in comment.splitlines()).encode("utf-8")
    atomic_write(path, header + vertex_lines(np.asarray(vertices)) + polygon_lines(faces))


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
    face_text = polygon_lines(rig.faces if rig.faces is not None else rig.triangles)
    source = rig.provenance.label
    atomic_write(
        folder / "neutral.obj", f"# neutral of {source}\n".encode() + vertex_lines(rig.neutral) + face_text
    )
    for name, delta in zip(rig.names, rig.deltas, strict=True):
        header = f"# blendshape {name} of {source}\n".encode()
        atomic_write(folder / f"{name}.obj", header + vertex_lines(rig.neutral + delta) + face_text)
    manifest = {
        "format": "obj-folder",
        "neutral": "neutral.obj",
        "shapes": list(rig.names),
        "regions": {name: indices.tolist() for name, indices in rig.regions.items()},
        "units": rig.provenance.units or "unknown",
    }
    atomic_write(folder / MANIFEST, json.dumps(manifest, indent=1) + "\n")
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
