"""Wavefront OBJ meshes: a tolerant reader, polygon triangulation, and rigs as folders of OBJs.

A rig folder holds the neutral mesh (``neutral.obj`` unless told otherwise) and one OBJ per blendshape with
the same vertices and faces; the blendshape's name is its file stem. The folder may also hold ``rig.json``
(written by :func:`save_obj_folder`) that fixes the shape order and keeps regions and units.
"""

from __future__ import annotations

import io
import json
import re
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rigs._rig import Rig, RigError

MANIFEST = "rig.json"
_VERTEX_LINE = re.compile(r"^v[ \t]([^\n]*)", re.MULTILINE)
_FACE_LINE = re.compile(r"^f[ \t]([^\n]*)", re.MULTILINE)
#: Stems (any case) taken for the neutral mesh when the folder has no ``neutral.obj``: exporters and
#: artists also call it the basis (Blender's shape-key basis), base or rest shape.
NEUTRAL_STEMS = ("neutral", "basis", "base", "rest")
#: Decimal places `decimal_step` takes for rounding: coordinates with fewer are a design grid (integers,
#: halves), not rounded; more than 9 is below any noise floor.
_ROUNDING_DECIMALS = range(3, 10)
#: Coordinates sampled per file by `decimal_step`.
_STEP_SAMPLE = 3000
_UNSAFE_NAME = re.compile(r'[\\/:*?"<>|\x00-\x1f]')


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
        The file's text from its first ``f`` line on (line ends normalised; set by a full read), so that
        blendshape files written with the same face section are recognised without splitting it.
    """

    vertices: np.ndarray
    faces: tuple[np.ndarray, ...]
    groups: dict[str, np.ndarray] = field(default_factory=dict)
    face_lines: tuple[str, ...] = ()
    face_text: str = ""

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
    it, its face lines are those of ``faces_of`` and are not split again.

    Returns None when the file is unusual (indented lines, no vertices, extra values, comments after
    coordinates, a malformed number), leaving the line-by-line reader to handle it and name the line.
    """
    if text[:1] in (" ", "\t") or "\n " in text or "\n\t" in text or "\\" in text:
        return None
    rows = _VERTEX_LINE.findall(text)
    if not rows:
        return None
    values = _single_spaced_rows(rows)
    if values is None:
        try:
            values = np.array(" ".join(rows).split(), dtype=np.float64)
        except ValueError:
            return None
    if values.size != 3 * len(rows) or not np.isfinite(values).all():
        return None
    tail = faces_of.face_text if faces_of is not None else ""
    if tail and text.endswith(tail) and not _FACE_LINE.search(text, 0, len(text) - len(tail)):
        return ObjMesh(vertices=values.reshape(-1, 3), faces=(), face_lines=faces_of.face_lines)
    face_lines = _FACE_LINE.findall(text)
    joined = "\n".join(face_lines) + "\n"
    if "#" in joined or "\t" in joined or " \n" in joined:
        face_lines = [line.split("#", 1)[0].strip() for line in face_lines]
    return ObjMesh(vertices=values.reshape(-1, 3), faces=(), face_lines=tuple(face_lines))


def _single_spaced_rows(rows: list[str]) -> np.ndarray | None:
    """``x y z`` rows with single spaces as floats, by pandas' C parser (3-4 times numpy's speed on the
    tens of thousands of rows of each blendshape file); None for any other layout."""
    import pandas as pd

    try:
        table = pd.read_csv(io.StringIO("\n".join(rows)), sep=" ", header=None, dtype=np.float64)
    except (ValueError, pd.errors.ParserError):
        return None
    return table.to_numpy() if table.shape == (len(rows), 3) else None


def parse_obj(text: str, source: str, *, with_faces: bool = True, faces_of: ObjMesh | None = None) -> ObjMesh:
    """Read OBJ text: ``v`` positions and ``f`` polygons; everything else is skipped.

    Accepted: comments (``#`` to end of line), CRLF or CR line ends, ``\\`` line continuations,
    ``v x y z [w]`` and ``v x y z r g b`` (extra values ignored), scientific notation, face corners
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
        ``source:line: problem`` for a malformed vertex or face, an index of 0 or out of range,
        a non-finite coordinate, or a file without vertices.
    """
    text = text.replace("\r\n", "\n").replace("\r", "\n")
    if not with_faces:
        fast = _vertices_only(text, faces_of)
        if fast is not None:
            return fast
    vertex_rows: list[list[str]] = []
    vertex_line_numbers: list[int] = []
    face_lines: list[str] = []
    face_line_numbers: list[int] = []
    face_vertex_counts: list[int] = []
    group_faces: dict[str, list[int]] = {}
    current_groups: list[str] = []
    for number, line in _numbered_lines(text):
        if "#" in line:
            line = line.split("#", 1)[0]
        parts = line.split()
        if not parts:
            continue
        keyword = parts[0]
        if keyword == "v":
            vertex_rows.append(parts)
            vertex_line_numbers.append(number)
        elif keyword == "f":
            for name in current_groups:
                group_faces.setdefault(name, []).append(len(face_lines))
            face_lines.append(line.strip()[1:].strip())
            face_line_numbers.append(number)
            face_vertex_counts.append(len(vertex_rows))
        elif keyword == "g":
            current_groups = parts[1:] or ["default"]

    vertices = _vertices(vertex_rows, vertex_line_numbers, source)
    faces: tuple[np.ndarray, ...] = ()
    if with_faces and face_lines:
        faces = _faces(face_lines, face_line_numbers, face_vertex_counts, len(vertices), source)
    groups = {name: np.asarray(indices, dtype=np.int64) for name, indices in group_faces.items()}
    first_face = _FACE_LINE.search(text)
    return ObjMesh(
        vertices=vertices,
        faces=faces,
        groups=groups,
        face_lines=tuple(face_lines),
        face_text=text[first_face.start() :] if first_face and with_faces else "",
    )


def read_obj(path: str | Path, *, with_faces: bool = True, faces_of: ObjMesh | None = None) -> ObjMesh:
    """Read an OBJ file (see :func:`parse_obj`); a missing or unreadable file raises `RigError`."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as error:
        raise RigError(f"{path}: cannot read OBJ file ({error.strerror or error})") from None
    return parse_obj(text, str(path), with_faces=with_faces, faces_of=faces_of)


def _vertices(rows: list[list[str]], line_numbers: list[int], source: str) -> np.ndarray:
    if not rows:
        raise RigError(f"{source}: no vertices ('v' lines)")
    short = [i for i, row in enumerate(rows) if len(row) < 4]
    if short:
        i = short[0]
        raise RigError(f"{source}:{line_numbers[i]}: vertex needs x y z, got {' '.join(rows[i])!r}")
    try:
        vertices = np.array([value for row in rows for value in row[1:4]], dtype=np.float64).reshape(-1, 3)
    except ValueError:
        for i, row in enumerate(rows):
            try:
                [float(value) for value in row[1:4]]
            except ValueError:
                raise RigError(
                    f"{source}:{line_numbers[i]}: vertex has a non-numeric coordinate: {' '.join(row)!r}"
                ) from None
        raise
    finite = np.isfinite(vertices).all(axis=1)
    if not finite.all():
        i = int(np.flatnonzero(~finite)[0])
        raise RigError(
            f"{source}:{line_numbers[i]}: vertex {i} has a non-finite coordinate {' '.join(rows[i])!r}"
        )
    return vertices


def _faces(
    lines: list[str], line_numbers: list[int], vertex_counts: list[int], n_vertices: int, source: str
) -> tuple[np.ndarray, ...]:
    corners = [line.split() for line in lines]
    sizes = np.fromiter((len(c) for c in corners), dtype=np.int64, count=len(corners))
    if (sizes < 3).any():
        i = int(np.flatnonzero(sizes < 3)[0])
        raise RigError(f"{source}:{line_numbers[i]}: face needs at least 3 corners, got 'f {lines[i]}'")
    tokens = [corner.partition("/")[0] for face in corners for corner in face]
    try:
        flat = np.array(tokens, dtype=np.int64)
    except ValueError:
        bad = next(i for i, face in enumerate(corners) if not all(_is_int(c.partition("/")[0]) for c in face))
        raise RigError(
            f"{source}:{line_numbers[bad]}: face has a malformed vertex index: 'f {lines[bad]}'"
        ) from None
    face_of_corner = np.repeat(np.arange(len(corners)), sizes)
    defined_before = np.asarray(vertex_counts, dtype=np.int64)[face_of_corner]
    flat = np.where(flat < 0, flat + defined_before, flat - 1)
    bad_corner = (flat < 0) | (flat >= n_vertices)
    if bad_corner.any():
        i = int(face_of_corner[np.flatnonzero(bad_corner)[0]])
        raise RigError(
            f"{source}:{line_numbers[i]}: face indexes a vertex outside 1..{n_vertices} "
            f"(or before any vertex is defined): 'f {lines[i]}'"
        )
    return tuple(np.split(flat, np.cumsum(sizes)[:-1]))


def _is_int(token: str) -> bool:
    try:
        int(token)
    except ValueError:
        return False
    return True


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
    Vectorised per polygon size; only concave n-gons (5+ corners) are clipped one by one, O(n^2) each.
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
    """Corner triples of an ear-clipped simple polygon (corners counter-clockwise about ``normal``)."""
    axis = int(np.argmax(np.abs(normal)))
    plane = np.delete(points, axis, axis=1)
    if (normal[axis] < 0) != (axis == 1):
        plane = plane[:, ::-1]
    remaining = list(range(len(points)))
    triangles = []
    while len(remaining) > 3:
        for position, corner in enumerate(remaining):
            before, after = remaining[position - 1], remaining[(position + 1) % len(remaining)]
            if _is_ear(plane, before, corner, after, remaining):
                triangles.append((before, corner, after))
                remaining.pop(position)
                break
        else:
            triangles.append((remaining[0], remaining[1], remaining[2]))
            remaining.pop(1)
    triangles.append(tuple(remaining))
    return np.asarray(triangles, dtype=np.int64)


def _is_ear(plane: np.ndarray, before: int, corner: int, after: int, remaining: list[int]) -> bool:
    a, b, c = plane[before], plane[corner], plane[after]
    if _cross2(b - a, c - b) <= 0:
        return False
    others = [i for i in remaining if i not in (before, corner, after)]
    if not others:
        return True
    p = plane[others]
    inside = (_cross2(b - a, p - a) >= 0) & (_cross2(c - b, p - b) >= 0) & (_cross2(a - c, p - c) >= 0)
    return not inside.any()


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
        its file stem, in sorted order. With ``rig.json`` (see :func:`save_obj_folder`), its ``shapes`` list
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
        blendshape whose vertex count or faces differ from the neutral's (the first such file), two
        files with one stem, a malformed line, a non-finite coordinate.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise RigError(f"{folder}: no such folder of OBJ files")
    manifest = _read_manifest(folder)
    neutral_path = _neutral_path(folder, neutral if neutral is not None else manifest.get("neutral"))
    shape_paths = _shape_paths(folder, neutral_path, manifest.get("shapes"))
    if not shape_paths and "shapes" not in manifest:  # (a rig.json may list none, as written)
        raise RigError(
            f"{neutral_path}: one OBJ holds no blendshapes, and its folder has no other OBJ files "
            "(one per blendshape)"
        )

    base = read_obj(neutral_path)
    if not base.faces:
        raise RigError(f"{neutral_path}: the neutral mesh has no faces")
    deltas = np.empty((len(shape_paths), len(base.vertices), 3))
    step = decimal_step(base.vertices)
    for k, path in enumerate(shape_paths.values()):
        shape = read_obj(path, with_faces=False, faces_of=base)
        _check_same_mesh(base, shape, path, neutral_path)
        np.subtract(shape.vertices, base.vertices, out=deltas[k])
        step = max(step, decimal_step(shape.vertices))

    triangles = triangulate(base.faces, base.vertices)
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
    try:
        declared = _neutral_path(folder, manifest.get("neutral"))
    except RigError:
        declared = None
    if declared is not None and declared.resolve() != path.resolve():
        raise RigError(
            f"{path}: not the neutral of its folder ({declared.name} is); load {declared} or the folder"
        )
    return load_obj_folder(folder, neutral=path.name)


def _read_manifest(folder: Path) -> dict:
    path = folder / MANIFEST
    if not path.is_file():
        return {}
    try:
        manifest = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as error:
        raise RigError(f"{path}: not a readable JSON manifest ({error})") from None
    if not isinstance(manifest, dict) or not isinstance(manifest.get("shapes", []), list):
        raise RigError(f"{path}: expected an object with a 'shapes' list of blendshape names")
    return manifest


def _neutral_path(folder: Path, neutral: str | Path | None) -> Path:
    if neutral is None and not (folder / "neutral.obj").is_file():
        named = sorted(
            p for p in folder.iterdir() if p.suffix.lower() == ".obj" and p.stem.lower() in NEUTRAL_STEMS
        )
        if len(named) > 1:
            listed = ", ".join(p.name for p in named)
            raise RigError(f"{folder}: several OBJ files could be the neutral ({listed}); pass neutral=NAME")
        if named:
            return named[0]
    path = Path(neutral) if neutral is not None else Path("neutral.obj")
    if not path.is_absolute():
        path = folder / path
    if path.suffix.lower() != ".obj" and not path.is_file():
        path = path.with_name(path.name + ".obj")
    if not path.is_file():
        present = sorted(p.name for p in folder.iterdir() if p.suffix.lower() == ".obj")[:5]
        hint = f"; OBJ files here: {', '.join(present)}" if present else "; the folder has no OBJ files"
        raise RigError(
            f"{path}: neutral mesh not found (pass neutral=NAME, or load the neutral OBJ's path){hint}"
        )
    return path


def _shape_paths(folder: Path, neutral_path: Path, listed: list | None) -> dict[str, Path]:
    if listed is not None:
        paths = {str(name): folder / f"{name}.obj" for name in listed}
        if len(paths) != len(listed):
            duplicate = next(name for name in listed if listed.count(name) > 1)
            raise RigError(f"{folder / MANIFEST}: duplicate blendshape name {duplicate!r}")
        missing = [path for path in paths.values() if not path.is_file()]
        if missing:
            raise RigError(f"{missing[0]}: blendshape listed in {MANIFEST} but the file is missing")
        return paths
    paths: dict[str, Path] = {}
    for path in sorted(folder.iterdir()):
        if path.suffix.lower() != ".obj" or not path.is_file() or path.resolve() == neutral_path.resolve():
            continue
        if path.stem in paths:
            raise RigError(f"{path}: duplicate blendshape name {path.stem!r} (also {paths[path.stem].name})")
        paths[path.stem] = path
    return paths


def _check_same_mesh(base: ObjMesh, shape: ObjMesh, path: Path, neutral_path: Path) -> None:
    if len(shape.vertices) != len(base.vertices):
        expected = len(base.vertices)
        raise RigError(
            f"{path}: {len(shape.vertices)} vertices, but the neutral {neutral_path.name} has {expected}"
        )
    if not shape.face_lines or shape.face_lines == base.face_lines:
        return
    faces = read_obj(path).faces
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


def _face_text(faces: Sequence[np.ndarray]) -> str:
    if faces_are_triangles(faces):
        one_based = np.asarray(faces, dtype=np.int64).reshape(-1, 3) + 1
        return ("f %d %d %d\n" * len(one_based)) % tuple(one_based.ravel().tolist())
    return "".join("f " + " ".join(map(str, (face + 1).tolist())) + "\n" for face in faces)


def _vertex_text(vertices: np.ndarray) -> str:
    return ("v %r %r %r\n" * len(vertices)) % tuple(vertices.ravel().tolist())


def write_obj(
    path: str | Path, vertices: np.ndarray, faces: Sequence[np.ndarray], *, comment: str = ""
) -> None:
    """Write one OBJ: ``v`` lines with shortest round-trip floats, then 1-based ``f`` lines."""
    header = "".join(f"# {line}\n" for line in comment.splitlines())
    Path(path).write_text(header + _vertex_text(np.asarray(vertices)) + _face_text(faces), encoding="utf-8")


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
    faces = rig.faces if rig.faces is not None else tuple(rig.triangles)
    face_text = _face_text(faces)
    source = rig.meta.get("source", "rig")
    (folder / "neutral.obj").write_text(f"# neutral of {source}\n" + _vertex_text(rig.neutral) + face_text)
    for name, delta in zip(rig.names, rig.deltas, strict=True):
        text = f"# blendshape {name} of {source}\n" + _vertex_text(rig.neutral + delta) + face_text
        (folder / f"{name}.obj").write_text(text, encoding="utf-8")
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
