"""The meshes of a scanning session: the neutral and each expression as OBJ text that keeps the source's
own lines.

An expression is the template neutral plus the sum of its shapes (primary and extra examples; Carrigan et
al. 2020, eq. 1 with 0/1 weights). When the rig came from an OBJ (a folder of OBJs, or the Face Units base
mesh), every file is that OBJ with only its ``v`` lines replaced (`rigs.rig_surface`): texture
coordinates, normals, groups, material references and face corners pass through as written. Otherwise the
files hold what the rig has: vertices and its polygons (or triangles).

Coordinates are written at the source's precision (`precision`). On a target character (``--target``), an
expression is the target's neutral plus the template's deltas, roughly what the actor's scan should look
like; a target OBJ lends its own lines to those files.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

NEUTRAL_FILE = "neutral.obj"
ON_TARGET = "on_target"


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
    from rigs._obj import decimal_step

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
    surface: Any | None


def read_target(path: str | Path | None, rig: Any) -> TargetMesh | None:
    """The target neutral of ``path``: an OBJ (its ``v`` lines and surface) or any rig file (its neutral).

    Raises
    ------
    rigs.RigError
        When the file cannot be read or has another vertex count than the rig; the message names the file.
    """
    if path is None:
        return None
    import rigs
    from rigs._obj import parse_obj, read_surface

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
    return TargetMesh(path, vertices, surface)


def expression_poses(rig: Any, expressions: Sequence[Mapping[str, Any]]) -> np.ndarray:
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
    rig: Any, expressions: Sequence[Mapping[str, Any]], target: TargetMesh | None = None
) -> dict[str, str]:
    """File name -> OBJ text: ``neutral.obj``, ``expression_XX.obj`` and, with a target,
    ``on_target/expression_XX.obj``."""
    import rigs

    surface = rigs.rig_surface(rig) or rigs.plain_surface(rig)
    exact = precision(rig.neutral, rig.deltas)
    source = rig.meta.get("source", "rig")
    texts = {NEUTRAL_FILE: _text(surface, rig.neutral, exact, f"neutral of {source}")}
    deltas = expression_poses(rig, expressions)
    if target is not None:
        on_target = target.surface if target.surface is not None else surface
        target_precision = exact.combine(precision(target.vertices))
    for index, (delta, expression) in enumerate(zip(deltas, expressions, strict=True), start=1):
        name = expression_name(index, len(expressions))
        shapes = " ".join(expression["shapes"])
        texts[f"{name}.obj"] = _text(surface, rig.neutral + delta, exact, f"expression {index}: {shapes}")
        if target is not None:
            comment = f"expression {index} on the target {target.path.name}: {shapes}"
            texts[f"{ON_TARGET}/{name}.obj"] = _text(
                on_target, target.vertices + delta, target_precision, comment
            )
    return texts


def _text(surface: Any, vertices: np.ndarray, precision: Precision, comment: str) -> str:
    return surface.text(vertices, step=precision.step, single=precision.single, comment=comment)
