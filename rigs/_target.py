"""MakeHuman / MPFB ``.target`` sets over a base OBJ, optionally cropped to the region they move.

A ``.target`` file is a sparse blendshape: one ``vid dx dy dz`` line per moved vertex, ``vid`` a 0-based
index into the base mesh's ``v`` lines, ``#`` starting a comment. ``.target.gz`` files are read as well.
A target set can be given three ways (names are the file stems, without ``.target`` / ``.target.gz``;
folders and archives list them in name order, manifests in their own order):

* a folder: the base is its only ``*.obj`` (or ``base=``), the targets every ``*.target[.gz]`` below it;
* a ``.zip`` archive: the same, over archive members; ``targets=`` is a glob over member paths;
* a ``.json`` manifest ``{"base": "base.obj", "targets": [...] | "glob" | {name: file}, "units": "dm",
  "crop_rings": 2}`` with paths relative to the manifest.
"""

from __future__ import annotations

import fnmatch
import gzip
import json
import zipfile
from collections.abc import Mapping, Sequence
from pathlib import Path, PurePosixPath

import numpy as np
from scipy.sparse import csr_matrix

from rigs._obj import ObjMesh, faces_are_triangles, parse_obj, read_obj, triangulate
from rigs._rig import Rig, RigError

TARGET_SUFFIXES = (".target", ".target.gz")


def target_name(path: str) -> str:
    """Blendshape name of a target file: its file name without ``.target`` or ``.target.gz``."""
    name = PurePosixPath(path).name
    for suffix in TARGET_SUFFIXES:
        if name.endswith(suffix):
            return name[: -len(suffix)]
    return PurePosixPath(path).stem


def _decode(data: bytes, label: str) -> str:
    if label.endswith(".gz"):
        try:
            data = gzip.decompress(data)
        except (OSError, EOFError) as error:
            raise RigError(f"{label}: not a gzip file ({error})") from None
    return data.decode("utf-8", errors="replace")


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
    table = np.array(rows)
    try:
        ids = table[:, 0].astype(np.int64)
        displacements = table[:, 1:].astype(np.float64)
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
    unique, first, counts = np.unique(ids, return_index=True, return_counts=True)
    if (counts > 1).any():
        vertex = unique[counts > 1][0]
        lines = [numbers[i] for i in np.flatnonzero(ids == vertex)[:2]]
        raise RigError(f"{source}:{lines[1]}: vertex {vertex} is listed twice (also line {lines[0]})")
    return ids, displacements


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
        Recorded as ``meta["source"]``.
    base_label : str
        The base mesh's file, recorded as ``meta["base"]``.
    crop_rings : int, optional
        Keep only the vertices some target moves plus this many face rings (see :func:`crop`);
        ``None`` keeps the whole base mesh.
    units : str, optional
        Recorded as ``meta["units"]``.
    group_regions : mapping, optional
        OBJ group name -> region name; each becomes a region (its vertices that survive cropping).

    Raises
    ------
    RigError
        For a malformed target (see :func:`parse_target`), two targets with one name, or a base without faces.
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
    meta = {
        "source": source,
        "format": "makehuman-target",
        "base": base_label,
        "units": units or "unknown",
        "base_vertices": n_base,
        "base_vertex_ids": kept,
        "crop_rings": crop_rings,
    }
    return Rig(
        neutral=neutral,
        deltas=deltas,
        triangles=triangulate(faces, neutral),
        names=tuple(name for name, _, _ in targets),
        regions=regions,
        faces=None if faces_are_triangles(faces) else faces,
        meta=meta,
    )


def load_target_folder(
    folder: str | Path, *, base: str | Path | None = None, crop_rings: int | None = None
) -> Rig:
    """A rig from a folder holding a base OBJ and ``.target`` files (searched recursively, sorted by name)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise RigError(f"{folder}: no such folder of .target files")
    base_path = _pick_base(folder, [p for p in folder.iterdir() if p.suffix.lower() == ".obj"], base)
    found = [p for p in folder.rglob("*") if p.is_file() and p.name.endswith(TARGET_SUFFIXES)]
    paths = sorted(found, key=lambda p: (target_name(p.name), p))
    if not paths:
        raise RigError(f"{folder}: no .target files")
    targets = [(target_name(p.name), str(p), _decode(p.read_bytes(), str(p))) for p in paths]
    return assemble(
        read_obj(base_path), targets, source=str(folder), base_label=str(base_path), crop_rings=crop_rings
    )


def _pick_base(folder: Path, candidates: list[Path], base: str | Path | None) -> Path:
    if base is not None:
        path = Path(base) if Path(base).is_absolute() else folder / base
        if not path.is_file():
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
    """
    path = Path(path)
    if not path.is_file():
        raise RigError(f"{path}: no such archive")
    try:
        archive = zipfile.ZipFile(path)
    except (OSError, zipfile.BadZipFile) as error:
        raise RigError(f"{path}: not a zip archive ({error})") from None
    with archive:
        members = archive.namelist()
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
        base_mesh = parse_obj(archive.read(base).decode("utf-8", errors="replace"), f"{path}!{base}")
        texts = [(target_name(m), f"{path}!{m}", _decode(archive.read(m), f"{path}!{m}")) for m in chosen]
    return assemble(
        base_mesh,
        texts,
        source=str(path),
        base_label=f"{path}!{base}",
        crop_rings=crop_rings,
        units=units,
        group_regions=group_regions,
    )


def load_target_manifest(path: str | Path, *, crop_rings: int | None = None) -> Rig:
    """A rig from a JSON manifest naming a base OBJ and target files (see the module docstring)."""
    path = Path(path)
    try:
        manifest = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise RigError(f"{path}: no such manifest") from None
    except (OSError, ValueError) as error:
        raise RigError(f"{path}: not a readable JSON manifest ({error})") from None
    if not isinstance(manifest, dict) or "base" not in manifest or "targets" not in manifest:
        raise RigError(f"{path}: a target-set manifest needs 'base' and 'targets'")
    root = path.parent
    listed = manifest["targets"]
    if isinstance(listed, str):
        files = {
            target_name(p.name): p for p in sorted(root.glob(listed)) if p.name.endswith(TARGET_SUFFIXES)
        }
        if not files:
            raise RigError(f"{path}: no .target files match {listed!r}")
    elif isinstance(listed, list):
        files = {}
        for entry in listed:
            name = target_name(str(entry))
            if name in files:
                raise RigError(f"{path}: duplicate blendshape name {name!r} ({entry} and {files[name].name})")
            files[name] = root / str(entry)
    elif isinstance(listed, dict):
        files = {str(name): root / str(entry) for name, entry in listed.items()}
    else:
        raise RigError(f"{path}: 'targets' must be a glob, a list of files or a name -> file mapping")
    missing = [p for p in files.values() if not p.is_file()]
    if missing:
        raise RigError(f"{missing[0]}: target listed in {path.name} is missing")
    texts = [(name, str(p), _decode(p.read_bytes(), str(p))) for name, p in files.items()]
    base_path = root / str(manifest["base"])
    rings = crop_rings if crop_rings is not None else manifest.get("crop_rings")
    return assemble(
        read_obj(base_path),
        texts,
        source=str(path),
        base_label=str(base_path),
        crop_rings=rings,
        units=manifest.get("units"),
    )
