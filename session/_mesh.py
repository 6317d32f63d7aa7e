"""The meshes of a scanning session: the neutral and each expression as OBJ text that keeps the source's
own lines.

An expression is the template neutral plus the sum of its shapes (primary and extra examples; Carrigan et
al. 2020, eq. 1 with 0/1 weights). When the rig came from an OBJ (a folder of OBJs, or the Face Units base
mesh), every file is that OBJ with only its ``v`` lines replaced (`rigs.rig_surface`): texture
coordinates, normals, groups, material references and face corners pass through as written. When it came
from glTF, the files carry what the glTF mesh holds besides positions (`rigs._gltf_surface.GltfSurface`): its
``TEXCOORD_0`` as ``vt`` lines (v flipped: glTF's texture origin is the top left, OBJ's the bottom left),
the neutral's ``NORMAL`` as ``vn`` lines, and a ``usemtl`` line per primitive material with the library
``materials.mtl`` beside them (each material's name and base colour); faces are ``f v/vt/vn``. Otherwise
the files hold what the rig has: vertices and its polygons (or triangles).

Coordinates are written at the source's precision (`precision`; a glTF rig's as float32, whatever its node's
transform made of them). On a target character (``--target``), an
expression is the target's neutral plus the template's deltas, roughly what the actor's scan should look
like; a target OBJ lends its own lines to those files.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from session._materials import material_files

if TYPE_CHECKING:
    from rigs import GltfSurface, ObjSurface, Rig

NEUTRAL_FILE = "neutral.obj"
ON_TARGET = "on_target"
MATERIALS_FILE = "materials.mtl"
#: The material of triangles whose glTF primitive names none (glTF's default material).
DEFAULT_MATERIAL = "gltf_default"


@dataclass(frozen=True)
class Precision:
    """How coordinates are written: ``step`` decimals (a fixed rounding step, 0 for none) or, without one,
    as float32 (``single``) or float64 shortest round-trip text."""

    step: float = 0.0
    single: bool = False

    def combine(self, other: Precision) -> Precision:
        """The precision of a sum of values of both precisions (the finer step; none if either has none)."""
        step = min(self.step, other.step) if self.step > 0 and other.step > 0 else 0.0
        return Precision(step, self.single and other.single and not step)


def precision(*arrays: np.ndarray) -> Precision:
    """The precision of values from a source holding ``arrays`` (e.g. a neutral and its deltas).

    A fixed rounding step (`rigs._obj.decimal_step`, on a sample of each array) when every array has one
    (the finest of them); else float32 when every value is a float32 (glTF); else float64.
    """
    from rigs import decimal_step

    steps, single = [], True
    for values in arrays:
        flat = np.asarray(values, dtype=np.float64).ravel()
        sample = flat[:: max(1, flat.size // 30000)]
        steps.append(decimal_step(sample) if sample.size else 0.0)
        single = single and bool(np.array_equal(sample.astype(np.float32).astype(np.float64), sample))
    step = min(steps) if steps and all(value > 0 for value in steps) else 0.0
    return Precision(step, single and not step)


@dataclass(frozen=True)
class TargetMesh:
    """The target character's neutral (``--target``): its positions, in the template's vertex order, and
    its OBJ lines when it is an OBJ."""

    path: Path
    vertices: np.ndarray
    surface: ObjSurface | None


def read_target(path: str | Path | None, rig: Rig) -> TargetMesh | None:
    """The target neutral of ``path``: an OBJ (its ``v`` lines and surface) or any rig file (its neutral).

    Raises
    ------
    rigs.RigError
        When the file cannot be read, has another vertex count than the rig, or lists its vertices in
        another order (`rigs.VertexOrder.check_target`); the message names the file.
    """
    if path is None:
        return None
    import rigs
    from rigs import VertexOrder, parse_obj, read_surface

    path = Path(path)
    surface = None
    if path.suffix.lower() == ".obj":
        surface = read_surface(path)
        vertices = parse_obj("\n".join(surface.lines[i] for i in surface.vertex_rows), str(path)).vertices
    else:
        vertices = rigs.load(path).neutral
    if vertices.shape != rig.neutral.shape:
        raise rigs.RigError(
            f"{path}: target neutral has {len(vertices)} vertices, the rig has {rig.n_vertices}; "
            "it must be the same mesh (same topology and vertex order)"
        )
    source = Path(rig.provenance.source or "the rig")
    VertexOrder(rig.neutral, rig.triangles, source).check_target(vertices, path)
    return TargetMesh(path, vertices, surface)


def expression_poses(rig: Rig, expressions: Sequence[Mapping[str, Any]]) -> np.ndarray:
    """(J, N, 3) template deltas of each expression: the sum of its shapes, extra examples included."""
    weights = np.zeros((len(expressions), rig.n_shapes))
    for row, expression in zip(weights, expressions, strict=True):
        row[rig.indices([*expression["shapes"], *expression.get("extra_examples", ())])] = 1.0
    return (
        np.tensordot(weights, rig.deltas, axes=1) if len(expressions) else np.zeros((0, *rig.neutral.shape))
    )


def expression_name(index: int, count: int) -> str:
    """``expression_XX`` for the 1-based ``index`` of ``count`` expressions (at least two digits)."""
    return f"expression_{index:0{max(2, len(str(count)))}d}"


def session_meshes(
    rig: Rig, expressions: Sequence[Mapping[str, Any]], target: TargetMesh | None = None
) -> Iterator[tuple[str, str | bytes]]:
    """(file name, OBJ file), one file at a time: ``neutral.obj``, ``expression_XX.obj`` and, with a
    target, ``on_target/expression_XX.obj``; ``materials.mtl`` (also in ``on_target/`` when those files
    use it) for a glTF rig with materials."""
    import rigs

    surface, library = rigs.rig_surface(rig), None
    if surface is None:
        surface, library = gltf_surface(rig) or (rigs.plain_surface(rig), None)
    exact = precision(rig.neutral, rig.deltas)
    if rig.provenance.single and not exact.step:  # (float32 in the file, float64 after a node's transform)
        exact = Precision(single=True)
    source = rig.provenance.label
    yield NEUTRAL_FILE, _obj(surface, rig.neutral, exact, f"neutral of {source}")
    if library is not None:
        yield MATERIALS_FILE, library
    yield from _copied_materials(rig, surface)
    deltas = expression_poses(rig, expressions)
    if target is not None:
        on_target = target.surface if target.surface is not None else surface
        target_precision = exact.combine(precision(target.vertices))
        if library is not None and target.surface is None:
            yield f"{ON_TARGET}/{MATERIALS_FILE}", library
        if target.surface is None:  # (read again rather than held: maps may be hundreds of MB)
            yield from ((f"{ON_TARGET}/{name}", data) for name, data in _copied_materials(rig, surface))
        else:
            found = material_files(target.surface, target.path, target.path.parent)
            yield from ((f"{ON_TARGET}/{name}", data) for name, data in found if _free(name))
    for index, (delta, expression) in enumerate(zip(deltas, expressions, strict=True), start=1):
        name = expression_name(index, len(expressions))
        shapes = " ".join(expression["shapes"])
        yield f"{name}.obj", _obj(surface, rig.neutral + delta, exact, f"expression {index}: {shapes}")
        if target is not None:
            comment = f"expression {index} on the target {target.path.name}: {shapes}"
            posed = target.vertices + delta
            yield f"{ON_TARGET}/{name}.obj", _obj(on_target, posed, target_precision, comment)


def _copied_materials(rig: Rig, surface: ObjSurface) -> Iterator[tuple[str, bytes]]:
    """The material libraries and texture maps of the OBJ ``surface`` was read from (`session._materials`),
    read inside the rig's folder (the OBJ's own when the rig has none)."""
    obj = rig.surface.obj if rig.surface is not None else None
    if obj is None or surface.source != str(obj):
        return
    folder = rig.surface.folder if rig.surface.folder is not None else obj.parent
    yield from ((name, data) for name, data in material_files(surface, obj, folder) if _free(name))


def _free(name: str) -> bool:
    """Whether a copied material file's name leaves the session's own files alone."""
    first = name.split("/", 1)[0]
    return first not in (ON_TARGET, "pictures") and not name.endswith((".obj", ".json", ".html", ".glb"))


def _obj(surface: ObjSurface, vertices: np.ndarray, precision: Precision, comment: str) -> bytes:
    return surface.data(vertices, step=precision.step, single=precision.single, comment=comment)


def gltf_surface(rig: Rig) -> tuple[ObjSurface, str | None] | None:
    """The OBJ lines of a rig read from glTF with its texture coordinates, normals and materials, and the
    text of its material library (None without materials); None when the rig has no such data or its
    triangles are no longer those the data describes.

    Triangles of a primitive without a material take glTF's default material (white), named
    ``DEFAULT_MATERIAL`` when the mesh has other materials.

    Returns
    -------
    (rigs.ObjSurface, str or None) or None
    """
    import rigs

    surface = rig.surface.gltf if rig.surface is not None else None
    if surface is None or not _describes(surface, rig):
        return None
    materials = list(surface.materials)
    if materials and (surface.material < 0).any():
        materials.append((DEFAULT_MATERIAL, (1.0, 1.0, 1.0)))  # index -1: the last
    uv_rows = np.flatnonzero(~np.isnan(surface.uvs[:, 0]))
    normal_rows = np.flatnonzero(~np.isnan(surface.normals[:, 0]))
    lines = [f"mtllib {MATERIALS_FILE}"] if materials else []
    first_vertex = len(lines)
    lines += ["v 0 0 0"] * rig.n_vertices
    u, v = surface.uvs[uv_rows].astype(np.float32).T  # (str of a float32: its shortest text)
    lines += [f"vt {a} {b}" for a, b in zip(map(str, u), map(str, np.float32(1.0) - v), strict=True)]
    normals = surface.normals[normal_rows]
    lines += ("vn %.6f %.6f %.6f\n" * len(normals) % tuple(normals.ravel().tolist())).splitlines()
    numbers = (_numbering(rows, len(surface.uvs)) for rows in (uv_rows, normal_rows))
    lines += _face_lines(surface, *numbers, [name for name, _ in materials])
    source = rig.provenance.label
    rows = np.arange(first_vertex, first_vertex + rig.n_vertices)
    obj = rigs.ObjSurface(tuple(lines), rows, ("",) * rig.n_vertices, source)
    return obj, (_library(materials, source) if materials else None)


def _describes(surface: GltfSurface, rig: Rig) -> bool:
    """Whether ``surface``'s triangles are ``rig``'s (the rig was not cut or re-triangulated since)."""
    corners, vertex_map = surface.corners, surface.vertex_map
    return (
        corners.shape == rig.triangles.shape
        and len(vertex_map) > 0
        and int(vertex_map.max()) < rig.n_vertices
        and bool(np.array_equal(vertex_map[corners], rig.triangles))
    )


def _numbering(rows: np.ndarray, count: int) -> np.ndarray:
    """(count,) 1-based line number among ``rows`` of each glTF vertex, 0 for those not in ``rows``."""
    numbers = np.zeros(count, dtype=np.int64)
    numbers[rows] = np.arange(1, len(rows) + 1)
    return numbers


#: Corner formats of ``f`` lines by what a triangle has: 2 * (texture coordinates) + (normals).
_CORNERS = {0: "%d", 1: "%d//%d", 2: "%d/%d", 3: "%d/%d/%d"}


def _face_lines(
    surface: GltfSurface, uv_number: np.ndarray, normal_number: np.ndarray, names: Sequence[str]
) -> list[str]:
    """``usemtl`` and ``f v/vt/vn`` lines, a ``usemtl`` before each run of triangles of one material
    (when there are ``names``); a triangle has ``vt`` (``vn``) indices when all its corners have texture
    coordinates (normals)."""
    corners = surface.corners
    vertex = surface.vertex_map[corners] + 1
    uv, normal = uv_number[corners], normal_number[corners]
    kind = 2 * (uv > 0).all(axis=1) + (normal > 0).all(axis=1)
    key = surface.material * 4 + kind
    starts = np.flatnonzero(np.r_[True, key[1:] != key[:-1]]).tolist()
    lines: list[str] = []
    for start, stop in zip(starts, [*starts[1:], len(key)], strict=True):
        material = int(surface.material[start])
        if names and (start == 0 or material != surface.material[start - 1]):
            lines.append(f"usemtl {names[material]}")
        columns = [vertex[start:stop], uv[start:stop], normal[start:stop]]
        chosen = [
            columns[0],
            *([columns[1]] if kind[start] >= 2 else []),
            *([columns[2]] if kind[start] % 2 else []),
        ]
        values = np.stack(chosen, axis=2).reshape(stop - start, -1)
        line = "f " + " ".join([_CORNERS[int(kind[start])]] * 3) + "\n"
        lines += (line * (stop - start) % tuple(values.ravel().tolist())).splitlines()
    return lines


def _library(materials: Sequence[tuple[str, tuple[float, float, float]]], source: str) -> str:
    """The MTL text of ``materials``: per material its name and diffuse colour (the glTF base colour)."""
    lines = [f"# materials of {source}"]
    for name, (red, green, blue) in materials:
        lines += [f"newmtl {name}", f"Kd {red:.6g} {green:.6g} {blue:.6g}"]
    return "\n".join(lines) + "\n"
