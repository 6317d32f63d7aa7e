"""USD (``.usd``, ``.usda``, ``.usdc``) rigs: a ``UsdGeom.Mesh`` with UsdSkel ``BlendShape`` targets.

A rig is one mesh: its ``points`` are the neutral, its polygons (``faceVertexCounts`` /
``faceVertexIndices``) the faces, and each ``BlendShape`` prim bound to it (``skel:blendShapeTargets``, named
by ``skel:blendShapes``) a delta blendshape: ``offsets`` at its ``pointIndices`` (every point when absent).
In-between shapes are not read (a `RigWarning` names them). Needs ``usd-core`` (the ``usd`` extra).

The file is untrusted: every layer it composes (sublayers, references and payloads, in variant sets too,
and value clips: their asset paths, manifest and template) must be a file inside its folder, checked
before the stage is opened, and every array is checked against the mesh's size. What ``pxr`` cannot read
(garbage text, a truncated ``.usdc``, a malformed clip) is a `RigError` naming the file.
"""

from __future__ import annotations

import contextlib
import re
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from registry import atomic_path
from rigs._provenance import METERS_PER_UNIT, Provenance, meters_per_unit
from rigs._rig import Rig, RigError, RigWarning
from rigs._safe import named_path, read_bytes, regular_file

USD_SUFFIXES = (".usd", ".usda", ".usdc")
#: The root layer's custom data key saying a rig's length unit is unknown (written without metersPerUnit).
UNITS_NOTE = "expressionPackingUnits"
_INVALID = re.compile(r"[^A-Za-z0-9_]")


@contextlib.contextmanager
def _readable(source: str) -> Iterator[None]:
    """Turn what ``pxr`` raises on a file it cannot read into a `RigError` naming ``source``."""
    from pxr import Tf

    try:
        yield
    except Tf.ErrorException as error:
        raise RigError(f"{source}: not a readable USD file ({_tf_reason(error)})") from None


def _tf_reason(error: Exception) -> str:
    """The reasons of a ``pxr.Tf.ErrorException`` (its quoted messages), without USD's source locations."""
    reasons = re.findall(r" : '(.*)'\s*$", str(error), flags=re.MULTILINE)
    return "; ".join(reasons) or " ".join(str(error).split())


def _pxr(source: str) -> Any:
    try:
        from pxr import Gf, Sdf, Usd, UsdGeom, UsdSkel, Vt
    except ImportError:
        raise RigError(
            f"{source}: reading or writing USD needs usd-core (pip install 'expression-packing-harness[usd]')"
        ) from None
    return Gf, Sdf, Usd, UsdGeom, UsdSkel, Vt


def load_usd(path: str | Path, *, mesh: str | None = None) -> Rig:
    """A rig from the blend shapes of one USD mesh.

    Parameters
    ----------
    path : path
    mesh : str, optional
        Prim path or name of the mesh; default: the mesh with the most blend shapes (ties: file order).

    Returns
    -------
    Rig with the mesh's world transform applied, ``provenance.format = "usd"``, ``provenance.mesh`` (its
    prim path) and ``provenance.units`` from the stage's ``metersPerUnit``.

    Raises
    ------
    RigError
        One line naming the file (and the mesh or blend shape): not a USD file, a composed layer outside
        the file's folder, no mesh with blend shapes, an unknown mesh, offsets and point indices of other
        lengths or indices outside the mesh, or non-finite values.
    """
    path = Path(path)
    source = str(path)
    regular_file(path)
    Gf, Sdf, Usd, UsdGeom, UsdSkel, Vt = _pxr(source)
    _check_layers(Sdf, path, source)
    with _readable(source):
        return _read_stage(path, source, mesh)


def _read_stage(path: Path, source: str, mesh: str | None) -> Rig:
    """`load_usd` once every layer the file composes is known to lie in its folder."""
    Gf, Sdf, Usd, UsdGeom, UsdSkel, Vt = _pxr(source)
    stage = Usd.Stage.Open(str(path))
    if stage is None:
        raise RigError(f"{source}: not a readable USD stage")
    candidates, unbound = [], []
    for prim in stage.Traverse():
        if not prim.IsA(UsdGeom.Mesh):
            continue
        relation = prim.GetRelationship("skel:blendShapeTargets")
        if not (relation and relation.GetTargets()):
            continue
        if prim.HasAPI(UsdSkel.BindingAPI):
            candidates.append((prim, relation.GetTargets()))
        else:
            unbound.append(str(prim.GetPath()))
    if not candidates and unbound:
        raise RigError(
            f"{source}: mesh {unbound[0]} has skel:blendShapeTargets but does not apply the SkelBindingAPI "
            '(prepend apiSchemas = ["SkelBindingAPI"] to it)'
        )
    if not candidates:
        raise RigError(f"{source}: no mesh with UsdSkel blend shapes (skel:blendShapeTargets)")

    if mesh is not None:
        chosen = [c for c in candidates if str(c[0].GetPath()) == mesh or c[0].GetName() == mesh]
        if not chosen:
            listed = ", ".join(str(c[0].GetPath()) for c in candidates)
            raise RigError(f"{source}: no mesh {mesh!r} with blend shapes (meshes: {listed})")
        prim, targets = chosen[0]
    else:
        prim, targets = max(candidates, key=lambda c: len(c[1]))
        others = [
            f"{c[0].GetPath()} ({len(c[1])} blend shape{'s' if len(c[1]) > 1 else ''})"
            for c in candidates
            if c[0] != prim
        ] + [f"{path} (skel:blendShapeTargets without the SkelBindingAPI)" for path in unbound]
        if others:  # (eyes, teeth, a tongue with their own blend shapes)
            warnings.warn(
                f"{source}: only one mesh is read; left out: {', '.join(others)} (read another with "
                "mesh=PATH: harness rigs convert --mesh PATH)",
                RigWarning,
                stacklevel=3,
            )
    label = f"{source}: mesh {prim.GetPath()}"
    geometry = UsdGeom.Mesh(prim)
    points = geometry.GetPointsAttr()
    if points.Get() is None and points.GetNumTimeSamples():
        raise RigError(
            f"{label}: its points have no default value, only {points.GetNumTimeSamples()} time samples; "
            "save the rest pose as the points' default value"
        )
    neutral = _finite(
        np.asarray(geometry.GetPointsAttr().Get() or [], dtype=np.float64).reshape(-1, 3), label
    )
    counts = np.asarray(geometry.GetFaceVertexCountsAttr().Get() or [], dtype=np.int64)
    corners = np.asarray(geometry.GetFaceVertexIndicesAttr().Get() or [], dtype=np.int64)
    if counts.sum() != len(corners) or (counts < 3).any():
        raise RigError(f"{label}: faceVertexCounts do not add up to the {len(corners)} faceVertexIndices")
    if len(corners) and (corners.min() < 0 or corners.max() >= len(neutral)):
        raise RigError(f"{label}: a face indexes a point outside 0..{len(neutral) - 1}")
    faces = tuple(np.split(corners, np.cumsum(counts)[:-1])) if len(counts) else ()
    binding = UsdSkel.BindingAPI(prim)
    names = list(binding.GetBlendShapesAttr().Get() or [])  # (optional: else the target prims' names)
    if names and len(names) != len(targets):
        raise RigError(f"{label}: {len(names)} skel:blendShapes names for {len(targets)} targets")
    named = bool(names)
    deltas = np.zeros((len(targets), len(neutral), 3))
    for k, target in enumerate(targets):
        shape = UsdSkel.BlendShape(stage.GetPrimAtPath(target))
        where = f"{label} blend shape {target}"
        if not shape:
            raise RigError(f"{where}: the target is not a BlendShape prim")
        offsets = _finite(
            np.asarray(shape.GetOffsetsAttr().Get() or [], dtype=np.float64).reshape(-1, 3), where
        )
        indices = shape.GetPointIndicesAttr().Get()
        points = np.arange(len(neutral)) if indices is None else np.asarray(indices, dtype=np.int64)
        if len(points) != len(offsets):
            raise RigError(f"{where}: {len(offsets)} offsets for {len(points)} point indices")
        if len(points) and (points.min() < 0 or points.max() >= len(neutral)):
            raise RigError(f"{where}: a point index is outside 0..{len(neutral) - 1}")
        deltas[k, points] = offsets
        if shape.GetInbetweens():
            warnings.warn(f"{where}: in-between shapes left out", RigWarning, stacklevel=2)
        if not named:
            names.append(shape.GetPrim().GetName())
    matrix = np.asarray(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode.Default()))
    if not np.allclose(matrix, np.eye(4)):  # (USD matrices act on row vectors)
        neutral = neutral @ matrix[:3, :3] + matrix[3, :3]
        deltas = deltas @ matrix[:3, :3]
    from rigs._triangulate import faces_are_triangles, triangulate

    meters = float(UsdGeom.GetStageMetersPerUnit(stage))  # (USD's default when not authored: 0.01, cm)
    unknown = not stage.HasAuthoredMetadata("metersPerUnit") and (
        stage.GetRootLayer().customLayerData.get(UNITS_NOTE) == "unknown"
    )
    provenance = Provenance(
        source=source,
        format="usd",
        mesh=str(prim.GetPath()),
        units="unknown"
        if unknown
        else next(
            (unit for unit, value in METERS_PER_UNIT.items() if np.isclose(value, meters)), f"{meters:g} m"
        ),
    )
    return Rig(
        neutral=neutral,
        deltas=deltas,
        triangles=triangulate(faces, neutral),
        names=tuple(str(name) for name in names),
        faces=None if faces_are_triangles(faces) else faces,
        provenance=provenance,
    )


def _check_layers(Sdf: Any, path: Path, source: str) -> None:
    """Every layer ``path`` composes is a regular file inside its folder (refused before opening it): the
    sublayers, references and payloads of every layer, and its value clips (``UsdUtils`` lists the files a
    clip template names). Each layer's bytes are read through `rigs._safe`, so that they are the rig's
    content (`rigs._inputs`)."""
    from pxr import UsdUtils

    folder = path.parent
    pending, seen = [path], set()
    while pending:
        current = pending.pop()
        if current in seen:
            continue
        seen.add(current)
        read_bytes(current, root=folder)
        with _readable(str(current)):
            sublayers, references, payloads = UsdUtils.ExtractExternalReferences(str(current))
        origin = f"{source} layer {current.name}"
        for asset in dict.fromkeys([*sublayers, *references, *payloads]):
            if Sdf.FileFormat.FindByExtension(Path(asset).suffix.lstrip(".")) is None:
                continue  # not a layer (a texture, say): USD does not open it with the stage
            dependency = named_path(current.parent, asset, origin)
            if not dependency.resolve().is_relative_to(folder.resolve()):
                raise RigError(f"{source}: composes {asset!r}, outside the file's folder {folder}")
            regular_file(dependency, folder)
            pending.append(dependency)


def _finite(values: np.ndarray, label: str) -> np.ndarray:
    if not np.isfinite(values).all():
        raise RigError(f"{label}: holds a non-finite value")
    return values


def save_usd(rig: Rig, path: str | Path) -> Path:
    """Write ``rig`` as a USD stage: ``/Rig`` (a ``SkelRoot``) holding the mesh ``/Rig/Face`` with one
    ``BlendShape`` child per shape (``offsets`` and ``pointIndices`` of its moved vertices only) bound by
    ``skel:blendShapes`` (the names) and ``skel:blendShapeTargets``. ``.usda`` is text, ``.usd`` and
    ``.usdc`` binary; Y is up and ``metersPerUnit`` follows ``provenance.units`` when known. Positions and
    offsets are float32, as the schema stores them.

    Raises
    ------
    RigError
        When usd-core is missing or the file cannot be written.
    """
    path = Path(path)
    Gf, Sdf, Usd, UsdGeom, UsdSkel, Vt = _pxr(str(path))
    path.parent.mkdir(parents=True, exist_ok=True)
    stage = Usd.Stage.CreateInMemory(path.name)  # (the name's suffix chooses text or binary)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    meters = meters_per_unit(rig.provenance.units)
    if meters is not None:
        UsdGeom.SetStageMetersPerUnit(stage, meters)
    else:  # (no metersPerUnit would read as USD's default, centimetres)
        stage.GetRootLayer().customLayerData = {UNITS_NOTE: "unknown"}
    root = UsdSkel.Root.Define(stage, "/Rig")
    stage.SetDefaultPrim(root.GetPrim())
    mesh = UsdGeom.Mesh.Define(stage, "/Rig/Face")
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(rig.neutral, dtype=np.float32)))
    faces = rig.faces if rig.faces is not None else tuple(rig.triangles)
    counts = np.array([len(face) for face in faces], dtype=np.int32)
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(counts))
    corners = np.concatenate(faces).astype(np.int32) if faces else np.zeros(0, np.int32)
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(corners))
    binding = UsdSkel.BindingAPI.Apply(mesh.GetPrim())
    targets, used = [], set()
    for name, delta in zip(rig.names, rig.deltas, strict=True):
        identifier = _identifier(name, used)
        shape = UsdSkel.BlendShape.Define(stage, mesh.GetPath().AppendChild(identifier))
        moved = np.flatnonzero(np.any(delta != 0, axis=1)).astype(np.int32)
        shape.CreateOffsetsAttr(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(delta[moved], dtype=np.float32)))
        shape.CreatePointIndicesAttr(Vt.IntArray.FromNumpy(moved))
        targets.append(shape.GetPath())
    binding.CreateBlendShapesAttr(Vt.TokenArray(list(rig.names)))
    binding.CreateBlendShapeTargetsRel().SetTargets(targets)
    with atomic_path(path) as temporary:
        if not stage.GetRootLayer().Export(str(temporary)):
            raise RigError(f"{path}: cannot write the USD file")
    return path


def _identifier(name: str, used: set[str]) -> str:
    """A prim name for a shape name: letters, digits and ``_``, not starting with a digit, unique."""
    base = _INVALID.sub("_", name) or "shape"
    base = f"_{base}" if base[0].isdigit() else base
    identifier, number = base, 1
    while identifier in used:
        number += 1
        identifier = f"{base}_{number}"
    used.add(identifier)
    return identifier
