"""``harness pack``: one rig's reference expressions for a scanning session, as JSON and OBJ meshes.

``DIR/expressions.json`` holds exactly::

    {"rig": str, "solver": str,
     "params": {"mu": float, "alpha": float, "beta": float, "symmetry": bool},
     "pairs": [[name, name], ...],
     "expressions": [{"shapes": [name, ...], "extra_examples": [name, ...], "objective": float,
                      "status": str}, ...]}

with the expressions in sequence order (Algorithm 1), and ``DIR/expression_XX.obj`` (XX = 01, 02, ...) is
the template neutral plus the sum of that expression's shapes (primary and extra examples), on the rig's
original faces.
"""

from __future__ import annotations

import json
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from harness import _plugins as plugins
from harness._rigspec import resolve_rig

EXPRESSIONS_FILE = "expressions.json"


@dataclass(frozen=True)
class PackResult:
    """What `pack` wrote.

    Attributes
    ----------
    document : dict
        The content of ``expressions.json``.
    files : list of Path
        ``expressions.json``, then the expression meshes.
    notes : list of str
        What the user should know: what the analysis skipped or could not do (empty shapes, vertices
        without a mirror, no target), the symmetry pairs, and shapes left out of every expression.
    """

    document: dict[str, Any]
    files: list[Path]
    notes: list[str]


def parse_rejections(text: str | None) -> dict[int, set[str]]:
    """``"1:jawOpen,2:mouthSmile_L"`` -> ``{1: {"jawOpen"}, 2: {"mouthSmile_L"}}`` (1-based expressions).

    Raises
    ------
    ValueError
        For an entry that is not ``EXPR:NAME`` with a positive integer EXPR.
    """
    rejections: dict[int, set[str]] = {}
    for entry in (part.strip() for part in (text or "").split(",")):
        if not entry:
            continue
        index, _, name = entry.partition(":")
        if not name or not index.strip().isdigit() or int(index) < 1:
            raise ValueError(
                f"--reject entry {entry!r} is not EXPR:NAME with EXPR a 1-based expression number"
            )
        rejections.setdefault(int(index), set()).add(name.strip())
    return rejections


def target_neutral(path: str | None, rig: Any) -> np.ndarray | None:
    """The target character's neutral: the vertices of an OBJ (or the neutral of any rig file) with the
    template's vertex count and order.

    Raises
    ------
    rigs.RigError
        When the file has no vertices or another vertex count; the message names the file.
    """
    if path is None:
        return None
    import rigs

    if Path(path).suffix.lower() == ".obj":
        vertices = read_obj_vertices(Path(path))
    else:
        vertices = rigs.load(path).neutral
    if vertices.shape != rig.neutral.shape:
        raise rigs.RigError(
            f"{path}: target neutral has {len(vertices)} vertices, the rig has {rig.n_vertices}; "
            "it must be the same mesh (same topology and vertex order)"
        )
    return vertices


def read_obj_vertices(path: Path) -> np.ndarray:
    """(N, 3) positions of the ``v`` lines of an OBJ (faces, normals, texture coordinates, vertex colours and
    comments ignored; any line ends and indentation)."""
    import rigs

    try:
        rows = (line.split("#", 1)[0].split() for line in path.read_text(errors="replace").splitlines())
        vertices = np.array([row[1:4] for row in rows if row and row[0] == "v"], dtype=np.float64)
        vertices = vertices.reshape(-1, 3)
    except (OSError, UnicodeDecodeError, ValueError) as error:
        raise rigs.RigError(f"{path}: cannot read OBJ vertices ({error})") from None
    if not len(vertices) or not np.isfinite(vertices).all():
        raise rigs.RigError(f"{path}: no finite 'v x y z' vertex lines")
    return vertices


def pack(
    rig_argument: str,
    *,
    solver_name: str,
    out: Path,
    jmax: int | None,
    target: str | None = None,
    params: Mapping[str, Any],
    seed: int = 0,
    time_limit: float | None = None,
    rejections: Mapping[int, set[str]] | None = None,
    decide: Callable[[int, str], bool] | None = None,
) -> PackResult:
    """Pack one rig and write ``expressions.json`` and one OBJ per expression into ``out``.

    Parameters
    ----------
    rig_argument : str
        Rig file or folder (any format `rigs.load` reads) or a generator preset name.
    solver_name : str
        Solver plugin.
    out : Path
        Output directory (created).
    jmax : int, optional
        Most expressions.
    target : str, optional
        OBJ of the target character's neutral (for the distortion importance, eq. 6).
    params : mapping
        Packing parameters (``mu``, ``alpha``, ``beta``, ``symmetry``, ...).
    seed, time_limit
        Passed to every solve.
    rejections : mapping, optional
        1-based expression number -> shapes the artist rejects there (sec. 4.5.3).
    decide : callable, optional
        Interactive refinement: ``decide(expression, shape) -> accept?`` for every proposed shape.
    """
    import packing

    rig = resolve_rig(rig_argument, seed=seed)
    neutral = target_neutral(target, rig)
    solver = _refining(plugins.solver(solver_name), rig, rejections or {}, decide)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", packing.MissingTargetWarning)  # among the analysis notes
        analysis = packing.analyse(rig, neutral, **params)
    expressions = packing.sequence(
        rig, solver, analysis=analysis, jmax=jmax, time_limit=time_limit, seed=seed
    )
    packing.check(rig, expressions, pairs=analysis.pairs, **params)
    refined = bool(rejections) or decide is not None
    notes = [*analysis.notes, _symmetry_note(analysis), *_coverage_notes(analysis, expressions, refined)]
    expressions = [expression for expression in expressions if expression.shapes]  # nothing to scan
    document = {
        "rig": rig_argument,
        "solver": solver_name,
        "params": {
            key: params.get(key, default)
            for key, default in (("mu", 0.3), ("alpha", 0.5), ("beta", 0.0), ("symmetry", True))
        },
        "pairs": [list(pair) for pair in analysis.pairs],
        "expressions": [
            {
                "shapes": [str(name) for name in expression.shapes],
                "extra_examples": [str(name) for name in getattr(expression, "extra_examples", ())],
                "objective": float(expression.objective),
                "status": str(expression.status),
            }
            for expression in expressions
        ],
    }
    out.mkdir(parents=True, exist_ok=True)
    for stale in out.glob("expression_*.obj"):  # from an earlier, longer packing into the same folder
        stale.unlink()
    files = [_write_json(out / EXPRESSIONS_FILE, document)]
    files += _write_expression_meshes(rig, document["expressions"], out)
    return PackResult(document, files, notes)


def _coverage_notes(analysis: Any, expressions: Sequence[Any], refined: bool) -> list[str]:
    """Which packable shapes no expression holds, and why the sequence stopped before them: an expression
    came out empty (every proposal rejected, or the solver found nothing), else ``jmax`` was reached."""
    used = {name for expression in expressions for name in expression.shapes}
    missing = [
        name
        for name, ok in zip(analysis.rig.names, analysis.packable, strict=True)
        if ok and name not in used
    ]
    if not missing:
        return []
    empty = next((expression for expression in expressions if not expression.shapes), None)
    if empty is None:
        reason = f"--jmax {len(expressions)} reached"
    elif refined:
        reason = (
            f"every shape proposed for expression {empty.index} was rejected, so the sequence stopped there"
        )
    else:
        reason = (
            f"the solver found no expression {empty.index}: {empty.status}, {empty.message or 'no message'}"
        )
    return [f"{len(missing)} blendshapes in no expression ({reason}): {', '.join(missing)}"]


def _symmetry_note(analysis: Any) -> str:
    symmetry = analysis.symmetry
    if not analysis.params.symmetry:
        return "symmetry off: no pairs"
    return (
        f"{len(symmetry.pairs)} symmetry pairs kept together "
        f"({len(symmetry.shape_pairs)} mirror, {len(symmetry.motion_pairs)} motion)"
    )


def _refining(
    solver: Any, rig: Any, rejections: Mapping[int, set[str]], decide: Callable[[int, str], bool] | None
) -> Any:
    """Wrap the solver in `solvers.RefiningSolver` (sec. 4.5.3) when there is anything to decide."""
    if not rejections and decide is None:
        return solver
    unknown = sorted(name for names in rejections.values() for name in names if name not in rig.names)
    if unknown:
        rig.index(unknown[0])  # raises RigError naming the shape and close matches
    import solvers

    listed = solvers.rejecting({expression - 1: names for expression, names in rejections.items()})

    def accept(proposal: Any) -> bool:
        if not listed(proposal):
            return False
        return decide(proposal.expression + 1, proposal.label) if decide is not None else True

    return solvers.RefiningSolver(solver, accept)


def _write_json(path: Path, document: dict[str, Any]) -> Path:
    temp = path.with_name(f".{path.name}.partial")
    temp.write_text(json.dumps(document, indent=2) + "\n")
    temp.replace(path)
    return path


def _write_expression_meshes(rig: Any, expressions: Sequence[Mapping[str, Any]], out: Path) -> list[Path]:
    import transfer

    if not expressions:
        return []
    weights = np.zeros((len(expressions), rig.n_shapes))
    for row, expression in zip(weights, expressions, strict=True):
        row[rig.indices([*expression["shapes"], *expression["extra_examples"]])] = 1.0
    meshes = transfer.training_expressions(rig, weights)
    faces = _obj_face_text(rig.faces if rig.faces is not None else rig.triangles)  # shared by every file
    width = max(2, len(str(len(expressions))))
    paths = []
    for index, (vertices, expression) in enumerate(zip(meshes, expressions, strict=True), start=1):
        path = out / f"expression_{index:0{width}d}.obj"
        comment = f"expression {index}: {' '.join(expression['shapes'])}"
        path.write_text(_obj_header(comment) + _obj_vertex_text(vertices) + faces)
        paths.append(path)
    return paths


def write_obj(path: Path, vertices: np.ndarray, faces: Sequence[np.ndarray], *, comment: str = "") -> None:
    """Write one mesh as a Wavefront OBJ: ``v`` lines (round-trip floats), then 1-based ``f`` lines."""
    path.write_text(_obj_header(comment) + _obj_vertex_text(vertices) + _obj_face_text(faces))


def _obj_face_text(faces: Sequence[np.ndarray] | np.ndarray) -> str:
    """The 1-based ``f`` lines of polygons (a (T, 3) array of triangles, or a sequence of polygons)."""
    if isinstance(faces, np.ndarray) or all(len(face) == 3 for face in faces):
        corners = np.asarray(faces, dtype=np.int64).reshape(-1, 3) + 1
        return ("f %d %d %d\n" * len(corners)) % tuple(corners.ravel().tolist())
    return "".join("f " + " ".join(map(str, (np.asarray(face) + 1).tolist())) + "\n" for face in faces)


def _obj_vertex_text(vertices: np.ndarray) -> str:
    vertices = np.asarray(vertices, dtype=np.float64)
    return ("v %r %r %r\n" * len(vertices)) % tuple(vertices.ravel().tolist())


def _obj_header(comment: str) -> str:
    return "".join(f"# {line}\n" for line in comment.splitlines())
