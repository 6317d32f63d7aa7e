"""MakeHuman / MPFB ``.target`` sets over a base OBJ, optionally cropped to the region they move.

A ``.target`` file is a sparse blendshape: one ``vid dx dy dz`` line per moved vertex, ``vid`` a 0-based
index into the base mesh's ``v`` lines, ``#`` starting a comment. ``.target.gz`` files are read as well.
A target set can be given three ways (names are the file stems, without ``.target`` / ``.target.gz``;
folders and archives list them in name order, manifests in their own order):

* a folder: the base is its only ``*.obj`` (or ``base=``), the targets every ``*.target[.gz]`` below it;
* a ``.zip`` archive: the same, over archive members; ``targets=`` is a glob over member paths;
* a ``.json`` manifest ``{"base": "base.obj", "targets": [...] | "glob" | {name: file}, "units": "dm",
  "crop_rings": 2}`` with paths relative to the manifest.

Every file is read through :mod:`rigs._safe`: only regular files inside the set's folder (a manifest's
paths may not be absolute or leave it), and a target no larger than its base mesh allows: one line per
vertex of at most `MAX_LINE` bytes plus `SLACK` for comments (`target_limit`); a ``.target.gz`` is
inflated as a stream that stops at that cap, and archive members are capped the same way.
"""

from __future__ import annotations

import fnmatch
import json
import os
import re
import zipfile
from collections.abc import Mapping, Sequence
from pathlib import Path, PurePosixPath

import numpy as np
from scipy.sparse import csr_matrix

from rigs._obj import DECIMAL, ObjMesh, parse_obj, read_obj
from rigs._obj_folder import MANIFEST_LIMIT
from rigs._provenance import BaseMesh, Provenance
from rigs._rig import LARGEST_COORDINATE, Rig, RigError
from rigs._safe import (
    check_budget,
    gunzip,
    named_path,
    read_bytes,
    read_member,
    read_text,
    regular_file,
    rig_entries,
)
from rigs._triangulate import faces_are_triangles, triangulate

TARGET_SUFFIXES = (".target", ".target.gz")
#: A vertex index in ASCII decimal digits.
_INTEGER = re.compile(r"[+-]?[0-9]+")
#: Longest ``vid dx dy dz`` line a target is allowed per vertex (MakeHuman writes about 25 bytes).
MAX_LINE = 128
#: Bytes a target may hold beyond its vertex lines: comments, blank lines.
SLACK = 64 * 2**10
#: A base OBJ in an archive may inflate this many times its compressed size (OBJ text deflates 3-5 times),
#: and always to `BASE_ALLOWANCE` bytes.
BASE_RATIO = 16
BASE_ALLOWANCE = 16 * 2**20


def target_limit(n_vertices: int) -> int:
    """The most bytes a target for a base of ``n_vertices`` can need: a line per vertex, plus comments."""
    return n_vertices * MAX_LINE + SLACK


def target_name(path: str) -> str:
    """Blendshape name of a target file: its file name without ``.target`` or ``.target.gz``."""
    name = PurePosixPath(path).name
    for suffix in TARGET_SUFFIXES:
        if name.endswith(suffix):
            return name[: -len(suffix)]
    return PurePosixPath(path).stem


def _decode(data: bytes, label: str, n_vertices: int) -> str:
    """The text of a target file's bytes, inflating ``.gz`` ones up to :func:`target_limit`."""
    if label.endswith(".gz"):
        data = gunzip(data, target_limit(n_vertices), label, f"a target for {n_vertices} vertices")
    return data.decode("utf-8-sig", errors="replace")  # (a byte-order mark is no part of the first line)


def _read_target(path: Path, root: Path, n_vertices: int) -> str:
    """The text of the target file ``path`` (inside ``root``), no larger than its base allows."""
    limit = target_limit(n_vertices)
    if path.name.endswith(".gz"):  # (compressed text is smaller, unless it is noise: then gunzip stops it)
        limit *= 2
    data = read_bytes(path, root=root, limit=limit, why=f"a target for {n_vertices} vertices")
    return _decode(data, str(path), n_vertices)


def parse_target(text: str, source: str, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """Vertex indices (M,) and displacements (M, 3) of one ``.target`` file.

    Raises
    ------
    RigError
        ``source:line: problem`` for a line that is not ``vid dx dy dz``, a vertex index outside the base
        mesh, a vertex listed twice, or a non-finite displacement.
    """
    rows: list[list[str]] = []
    numbers: list[int] = []
    for number, line in enumerate(text.splitlines(), 1):
        if "#" in line:
            line = line.split("#", 1)[0]
        parts = line.split()
        if parts:
            rows.append(parts)
            numbers.append(number)
    if not rows:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 3))
    bad = next((i for i, row in enumerate(rows) if len(row) != 4), None)
    if bad is not None:
        raise RigError(f"{source}:{numbers[bad]}: expected 'vid dx dy dz', got {' '.join(rows[bad])!r}")
    words = " ".join(map(" ".join, rows))
    if not words.isascii() or "_" in words:  # (numpy reads '1_0' and non-ASCII digits as Python does)
        bad = next(i for i, row in enumerate(rows) if not _is_strict_row(row))
        raise RigError(
            f"{source}:{numbers[bad]}: expected 'vid dx dy dz' in ASCII decimal notation, "
            f"got {' '.join(rows[bad])[:80]!r}"
        )
    table = np.array(rows)
    try:
        ids = table[:, 0].astype(np.int64)
        displacements = table[:, 1:].astype(np.float64)
    except OverflowError:  # an index past 64 bits
        bad = next(i for i, row in enumerate(rows) if abs(int(row[0])) >= 2**63)
        raise RigError(
            f"{source}:{numbers[bad]}: vertex {rows[bad][0][:40]} is outside the base mesh's "
            f"0..{n_vertices - 1}"
        ) from None
    except ValueError:
        bad = next(i for i, row in enumerate(rows) if not _is_target_row(row))
        raise RigError(
            f"{source}:{numbers[bad]}: expected 'vid dx dy dz', got {' '.join(rows[bad])!r}"
        ) from None
    outside = (ids < 0) | (ids >= n_vertices)
    if outside.any():
        i = int(np.flatnonzero(outside)[0])
        raise RigError(
            f"{source}:{numbers[i]}: vertex {ids[i]} is outside the base mesh's 0..{n_vertices - 1}"
        )
    finite = np.isfinite(displacements).all(axis=1)
    if not finite.all():
        i = int(np.flatnonzero(~finite)[0])
        raise RigError(f"{source}:{numbers[i]}: vertex {ids[i]} has a non-finite displacement")
    huge = (np.abs(displacements) > LARGEST_COORDINATE).any(axis=1)
    if huge.any():
        i = int(np.flatnonzero(huge)[0])
        raise RigError(
            f"{source}:{numbers[i]}: vertex {ids[i]} has a displacement beyond {LARGEST_COORDINATE:g}"
        )
    unique, first, counts = np.unique(ids, return_index=True, return_counts=True)
    if (counts > 1).any():
        vertex = unique[counts > 1][0]
        lines = [numbers[i] for i in np.flatnonzero(ids == vertex)[:2]]
        raise RigError(f"{source}:{lines[1]}: vertex {vertex} is listed twice (also line {lines[0]})")
    return ids, displacements


def _is_strict_row(row: list[str]) -> bool:
    """Whether a row is an integer and three numbers in ASCII decimal notation (no ``_``)."""
    return _INTEGER.fullmatch(row[0]) is not None and all(DECIMAL.fullmatch(value) for value in row[1:])


def _is_target_row(row: list[str]) -> bool:
    try:
        int(row[0])
        [float(value) for value in row[1:]]
    except ValueError:
        return False
    return True


def crop(
    faces: Sequence[np.ndarray], n_vertices: int, moved: np.ndarray, rings: int
) -> tuple[np.ndarray, list[int]]:
    """Vertices and faces of the region that ``moved`` vertices span, grown by ``rings`` face rings.

    One ring adds every vertex of every face touching the current set. Kept faces are those whose
    vertices are all kept; kept vertices are the moved ones plus those used by kept faces.

    Parameters
    ----------
    faces : sequence of int arrays
        Polygons of the base mesh.
    n_vertices : int
    moved : (n_vertices,) bool array
    rings : int >= 0

    Returns
    -------
    Sorted kept vertex indices, and the indices of kept faces.

    Notes
    -----
    Sparse face-vertex incidence products, O(rings * corners).
    """
    if rings < 0:
        raise RigError(f"crop_rings must be >= 0, got {rings}")
    sizes = np.fromiter((len(face) for face in faces), dtype=np.int64, count=len(faces))
    corners = np.concatenate(faces) if len(faces) else np.zeros(0, dtype=np.int64)
    rows = np.repeat(np.arange(len(faces)), sizes)
    incidence = csr_matrix((np.ones(len(corners)), (rows, corners)), shape=(len(faces), n_vertices))
    keep = moved.astype(np.float64)
    for _ in range(rings):
        touching = (incidence @ keep > 0).astype(np.float64)
        keep = ((incidence.T @ touching > 0) | (keep > 0)).astype(np.float64)
    inside = np.flatnonzero(incidence @ keep == sizes)
    used = np.zeros(n_vertices, dtype=bool)
    if len(inside):
        used[np.concatenate([faces[i] for i in inside])] = True
    return np.flatnonzero(used | moved), inside.tolist()


def assemble(
    base: ObjMesh,
    targets: Sequence[tuple[str, str, str]],
    *,
    source: str,
    base_label: str,
    crop_rings: int | None = None,
    units: str | None = None,
    group_regions: Mapping[str, str] | None = None,
) -> Rig:
    """A rig from a base mesh and parsed target texts.

    Parameters
    ----------
    base : ObjMesh
        The base mesh (its vertex order is what target ``vid`` index).
    targets : sequence of (name, label, text)
        Blendshape name, the file's label for messages, and its content.
    source : str
        Recorded as ``provenance.source``.
    base_label : str
        The base mesh's file, recorded with its vertex count and the base vertex of each rig vertex as
        ``provenance.base`` (`rigs.BaseMesh`).
    crop_rings : int, optional
        Keep only the vertices some target moves plus this many face rings (see :func:`crop`);
        ``None`` keeps the whole base mesh.
    units : str, optional
        Recorded as ``provenance.units``.
    group_regions : mapping, optional
        OBJ group name -> region name; each becomes a region (its vertices that survive cropping).

    Raises
    ------
    RigError
        For a malformed target (see :func:`parse_target`), two targets with one name, a base without faces,
        or more dense deltas than the files can describe (many empty targets over a large base; see
        :func:`rigs._safe.check_budget`).
    """
    if not base.faces:
        raise RigError(f"{base_label}: the base mesh has no faces")
    n_base = len(base.vertices)
    seen: dict[str, str] = {}
    for name, label, _ in targets:
        if name in seen:
            raise RigError(f"{label}: duplicate blendshape name {name!r} (also {seen[name]})")
        seen[name] = label
    parsed = [parse_target(text, label, n_base) for _, label, text in targets]
    moved = np.zeros(n_base, dtype=bool)
    for ids, displacements in parsed:
        moved[ids[np.any(displacements != 0, axis=1)]] = True

    if crop_rings is None:
        kept, kept_faces = np.arange(n_base), list(range(len(base.faces)))
    else:
        kept, kept_faces = crop(base.faces, n_base, moved, crop_rings)
    renumber = np.full(n_base, -1, dtype=np.int64)
    renumber[kept] = np.arange(len(kept))
    faces = tuple(renumber[base.faces[i]] for i in kept_faces)
    neutral = base.vertices[kept]
    described = sum(len(text) for _, _, text in targets) + 8 * n_base  # (a 'v' line takes 8 bytes or more)
    check_budget(
        source, f"{len(parsed)} targets of {len(kept)} vertices", len(parsed) * len(kept) * 24, described
    )
    deltas = np.zeros((len(parsed), len(kept), 3))
    for k, (ids, displacements) in enumerate(parsed):
        local = renumber[ids]
        present = local >= 0
        deltas[k, local[present]] = displacements[present]

    regions = {}
    for group, region in (group_regions or {}).items():
        if group in base.groups:
            local = renumber[base.group_vertices(group)]
            regions[region] = local[local >= 0]
    provenance = Provenance(
        source=source,
        format="makehuman-target",
        units=units or "unknown",
        base=BaseMesh(file=base_label, n_vertices=n_base, vertex_ids=kept),
        crop_rings=crop_rings,
    )
    return Rig(
        neutral=neutral,
        deltas=deltas,
        triangles=triangulate(faces, neutral),
        names=tuple(name for name, _, _ in targets),
        regions=regions,
        faces=None if faces_are_triangles(faces) else faces,
        provenance=provenance,
    )


def load_target_folder(
    folder: str | Path, *, base: str | Path | None = None, crop_rings: int | None = None
) -> Rig:
    """A rig from a folder holding a base OBJ and ``.target`` files (searched recursively, sorted by name).

    Every ``*.target[.gz]`` entry must be a regular file inside the folder (a dangling or looping link, a
    FIFO or a link leading outside is an error, not a shape left out); symbolic links to subfolders are
    not searched (a `RigWarning` names them).
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise RigError(f"{folder}: no such folder of .target files")
    objs = rig_entries(folder, lambda name: Path(name).suffix.lower() == ".obj", recursive=False)
    base_path = _pick_base(folder, objs, base)
    found = rig_entries(folder, lambda name: name.endswith(TARGET_SUFFIXES), recursive=True)
    paths = sorted(found, key=lambda p: (target_name(p.name), p))
    if not paths:
        raise RigError(f"{folder}: no .target files")
    explicit = base is not None and Path(base).is_absolute()
    mesh = read_obj(base_path, root=None if explicit else folder)
    n_vertices = len(mesh.vertices)
    targets = [(target_name(p.name), str(p), _read_target(p, folder, n_vertices)) for p in paths]
    return assemble(mesh, targets, source=str(folder), base_label=str(base_path), crop_rings=crop_rings)


def _pick_base(folder: Path, candidates: list[Path], base: str | Path | None) -> Path:
    if base is not None:
        path = Path(base) if Path(base).is_absolute() else folder / base
        if not os.path.lexists(path):
            raise RigError(f"{path}: base mesh not found")
        return path
    if len(candidates) != 1:
        found = ", ".join(sorted(p.name for p in candidates)) or "none"
        raise RigError(
            f"{folder}: expected exactly one base .obj beside the targets (found: {found}); pass base=NAME"
        )
    return candidates[0]


def load_target_zip(
    path: str | Path,
    *,
    base: str | None = None,
    targets: str = "*.target*",
    crop_rings: int | None = None,
    units: str | None = None,
    group_regions: Mapping[str, str] | None = None,
) -> Rig:
    """A rig from a zip archive (a ``.zip`` or a wheel) holding a base OBJ and ``.target`` files.

    Parameters
    ----------
    path : path
    base : str, optional
        Member path of the base OBJ; default: the archive's only ``.obj`` member.
    targets : str
        Glob over member paths (``*`` also crosses ``/``); members not ending in ``.target[.gz]`` are skipped.
    crop_rings, units, group_regions
        As for :func:`assemble`.

    Raises
    ------
    RigError
        For a file that is not a regular zip archive, a missing member, a member compressed other than by
        store or deflate, corrupt (CRC), claiming more than deflate can produce, or larger than it may be
        (the base: `BASE_RATIO` times its compressed size or `BASE_ALLOWANCE`; a target: `target_limit`),
        and as for :func:`assemble`.
    """
    path = Path(path)
    regular_file(path)
    try:
        archive = zipfile.ZipFile(path)
        members = archive.namelist()
    except (OSError, zipfile.BadZipFile, ValueError, NotImplementedError) as error:
        raise RigError(f"{path}: not a zip archive ({error})") from None
    with archive:
        if base is None:
            objs = [m for m in members if m.lower().endswith(".obj")]
            if len(objs) != 1:
                raise RigError(
                    f"{path}: expected exactly one .obj member (found {len(objs)}); pass base=MEMBER"
                )
            base = objs[0]
        if base not in members:
            raise RigError(f"{path}: no member {base!r} for the base mesh")
        matching = [m for m in members if fnmatch.fnmatchcase(m, targets) and m.endswith(TARGET_SUFFIXES)]
        chosen = sorted(matching, key=lambda m: (target_name(m), m))
        if not chosen:
            raise RigError(f"{path}: no .target members match {targets!r}")
        base_label = f"{path}!{base}"
        info = archive.getinfo(base)
        base_limit = max(BASE_ALLOWANCE, BASE_RATIO * info.compress_size)
        text = read_member(archive, base, base_label, base_limit, "an OBJ deflated this small")
        base_mesh = parse_obj(text.decode("utf-8", errors="replace"), base_label)
        n_vertices = len(base_mesh.vertices)
        limit, why = target_limit(n_vertices), f"a target for {n_vertices} vertices"
        texts = []
        for member in chosen:
            label = f"{path}!{member}"
            data = read_member(archive, member, label, limit, why)
            texts.append((target_name(member), label, _decode(data, label, n_vertices)))
    return assemble(
        base_mesh,
        texts,
        source=str(path),
        base_label=base_label,
        crop_rings=crop_rings,
        units=units,
        group_regions=group_regions,
    )


def load_target_manifest(path: str | Path, *, crop_rings: int | None = None) -> Rig:
    """A rig from a JSON manifest naming a base OBJ and target files (see the module docstring).

    Raises
    ------
    RigError
        For a manifest that is not JSON or lacks ``base`` and ``targets``, a path or glob in it that is
        absolute or leaves the manifest's folder, a listed file missing or not a regular file inside that
        folder, ``crop_rings`` or ``units`` of the wrong type, and as for :func:`assemble`.
    """
    path = Path(path)
    if not os.path.lexists(path):
        raise RigError(f"{path}: no such manifest")
    try:
        manifest = json.loads(read_text(path, limit=MANIFEST_LIMIT, why="a target-set manifest"))
    except (ValueError, RecursionError) as error:
        if isinstance(error, RigError):
            raise
        raise RigError(f"{path}: not a readable JSON manifest ({type(error).__name__}: {error})") from None
    if not isinstance(manifest, dict) or "base" not in manifest or "targets" not in manifest:
        raise RigError(f"{path}: a target-set manifest needs 'base' and 'targets'")
    root = path.parent
    origin = str(path)
    listed = manifest["targets"]
    if isinstance(listed, str):
        pattern = named_path(root, listed, origin).relative_to(root)
        files = {
            target_name(p.name): p
            for p in sorted(root.glob(str(pattern)))
            if p.name.endswith(TARGET_SUFFIXES)
        }
        if not files:
            raise RigError(f"{path}: no .target files match {listed!r}")
    elif isinstance(listed, list):
        files = {}
        for entry in listed:
            name = target_name(str(entry))
            if name in files:
                raise RigError(f"{path}: duplicate blendshape name {name!r} ({entry} and {files[name].name})")
            files[name] = named_path(root, entry, origin)
    elif isinstance(listed, dict):
        files = {str(name): named_path(root, entry, origin) for name, entry in listed.items()}
    else:
        raise RigError(f"{path}: 'targets' must be a glob, a list of files or a name -> file mapping")
    missing = [p for p in files.values() if not os.path.lexists(p)]
    if missing:
        raise RigError(f"{missing[0]}: target listed in {path.name} is missing")
    base_path = named_path(root, manifest["base"], origin)
    rings = crop_rings if crop_rings is not None else manifest.get("crop_rings")
    if rings is not None and (not isinstance(rings, int) or isinstance(rings, bool)):
        raise RigError(f"{path}: 'crop_rings' must be an integer, got {rings!r:.40}")
    units = manifest.get("units")
    if units is not None and not isinstance(units, str):
        raise RigError(f"{path}: 'units' must be a string, got {units!r:.40}")
    mesh = read_obj(base_path, root=root)
    texts = [(name, str(p), _read_target(p, root, len(mesh.vertices))) for name, p in files.items()]
    return assemble(mesh, texts, source=str(path), base_label=str(base_path), crop_rings=rings, units=units)
