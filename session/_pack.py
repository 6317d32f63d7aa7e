"""``harness pack``: one rig's reference expressions for a scanning session: the session folder.

``DIR/expressions.json`` holds::

    {"rig": str, "solver": str,
     "params": {"mu": float, "alpha": float, "beta": float, "symmetry": bool, "importance": bool,
                "max_per_expression": int | null, "extra_examples": bool,
                "together": [[name, name], ...], "apart": [[name, name], ...], "regions": str | null},
     "sequence": {"mode": "sequence" | "minimum", "jmax": int | null, "seed": int,
                  "time_limit": float | null, "timeout": float | null, "overlap": float,
                  "minimum": {"count": int, "lower_bound": int, "proven": bool, "time_limit": float}},
     "target": str | null,
     "pairs": [[name, name], ...],
     "expressions": [{"shapes": [name, ...], "extra_examples": [name, ...], "objective": float,
                      "status": str, "files": {"mesh": str, "on_target": str, "front": str,
                                               "front_pose": str, "three_quarter_pose": str}}, ...],
     "excluded": [{"shape": name, "reason": str}, ...],
     "constraints": {"default": bool, "rules": [{"rule": str, "kind": str, "shapes": [name, name],
                                                  "why": str}, ...], "notes": [str, ...]},
     "warnings": [str, ...]}

``params`` are the packing parameters used (`packing.PackingParams` names: ``max_per_expression`` is the
cap of sec. 6, ``together``/``apart`` every pair enforced, the artist's then the anatomical rules',
``regions`` the regions file given, if any); ``constraints`` says whether the anatomical rules were on, the
pairs they added (kind ``together``, ``apart``, or ``only_with`` for a shape left out unless scanned with the
other) with the reason of each, and the rules that yielded to the artist's pairs
(`session._constraints`); ``sequence`` the settings of the sequence: ``mode`` ``sequence`` is
Algorithm 1 (``jmax`` expressions at most, ``time_limit`` per solve and ``timeout`` for the whole packing in
seconds), ``minimum`` the fewest expressions that cover every shape (`session._minimum`, with
``minimum`` saying what was proved); ``overlap`` is the share of an item's active vertices the solver may
overlap (its declared ``capabilities.max_overlap``; 0 is eq. 3b); ``pairs`` the symmetry pairs enforced.
Together they are what the independent checker needs::

    packing.check(rig, doc["expressions"], pairs=doc["pairs"], overlap=doc["sequence"]["overlap"],
                  **doc["params"])

The expressions are in sequence order (priority: scan the first first); ``objective`` is the importance
sum (eq. 3a). ``excluded`` names every shape in no expression and why (left out by ``--exclude`` or by a
rule, empty, rejected, or the sequence stopped before it). ``warnings`` are the pairs of shapes in one
expression whose displacements largely cancel (`packing.find_cancellations`), a ``timeout`` that cut the
sequence short, and a minimum that was not proved.

Beside it (`session._files`): ``neutral.obj`` and ``expression_XX.obj`` (XX = 01, 02, ...: the template
neutral plus the sum of that expression's shapes, primary and extra examples) keeping the source OBJ's
texture coordinates, normals, groups, materials and faces; ``on_target/expression_XX.obj`` with
``target``; ``expressions.glb`` with ``glb``; ``pictures/expression_XX_front.png``,
``..._front_pose.png`` and ``..._three_quarter_pose.png``; and the scan sheet ``session.html``.

The folder is claimed with `registry.claim` (kind ``pack``) before any packing is done, under an exclusive
lock held until the session is written (another command claiming it meanwhile is refused with one line), and
its manifest lists every file written: a folder holding an earlier packing needs ``force`` to be replaced, a
folder holding anything else is refused, and the rig's own file or folder is never the output. The session
is written into a fresh folder beside it and renamed into its place as a whole (`OutputFolder.replace`), so
that whatever stops the command, the folder is as it was.
"""

from __future__ import annotations

import json
import warnings
from collections.abc import Callable, Collection, Iterable, Iterator, Mapping, Sequence
from contextlib import ExitStack, nullcontext
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from time import monotonic
from typing import TYPE_CHECKING, Any

import rigs
from harness import IsolatedSolver, check_settings, format_duration
from registry import HarnessError, OutputFolder, claim
from session._constraints import session_constraints
from session._files import session_files
from session._mesh import TargetMesh, read_target
from session._minimum import minimum_sequence
from session._pictures import prepare_scene
from session._solver import LoudSolver
from solvers import no_answer

if TYPE_CHECKING:
    from packing import Analysis, Expression, PackingProblem, Solution
    from rigs import Rig
    from solvers import Availability, Proposal, RefiningSolver

EXPRESSIONS_FILE = "expressions.json"

#: The packing parameters ``expressions.json`` records (`packing.PackingParams` names).
DOCUMENT_PARAMS = (
    "mu",
    "alpha",
    "beta",
    "symmetry",
    "importance",
    "max_per_expression",
    "extra_examples",
    "together",
    "apart",
    "regions",
)


@dataclass(frozen=True)
class PackResult:
    """What `pack` wrote.

    Attributes
    ----------
    document : dict
        The content of ``expressions.json``.
    files : list of Path
        ``expressions.json``, then the session's other files (meshes, pictures, scan sheet).
    notes : list of str
        What the user should know: what the analysis skipped or could not do (empty shapes, vertices
        without a mirror, no target), the symmetry pairs, and shapes left out of every expression.
    warnings : list of str
        The document's ``warnings`` (cancelling pairs, a ``timeout`` that cut the sequence short, a minimum
        that was not proved) but those the rig's reader gave, which were shown as they came.
    """

    document: dict[str, Any]
    files: list[Path]
    notes: list[str]
    warnings: list[str]


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
            raise HarnessError(
                f"--reject entry {entry!r} is not EXPR:NAME with EXPR a 1-based expression number"
            )
        rejections.setdefault(int(index), set()).add(name.strip())
    return rejections


@dataclass(frozen=True)
class PackConfig:
    """What one ``harness pack`` does: the rig, the solver, the packing and the session folder.

    Parameters
    ----------
    rig : str
        Rig file or folder (any format `rigs.load` reads), a generator preset name, or a fetched rig's
        name (``faceunits``).
    solver : str
        Solver plugin (not used with ``minimum``, which solves with CP-SAT).
    out : Path
        Output folder (created; see the module docstring for what it may already hold).
    params : mapping
        Packing parameters (``mu``, ``alpha``, ``beta``, ``symmetry``, ``together``, ``regions``, ...).
    jmax : int, optional
        Most expressions (not used with ``minimum``, which covers every shape).
    target : str, optional
        The target character's neutral (an OBJ, or any rig file) with the template's vertices: drives the
        distortion importance (eq. 6), and the expressions are also written on it.
    seed, time_limit
        Passed to every solve (with ``minimum``: to the proof and each ordered step; default
        `session._minimum.DEFAULT_TIME_LIMIT`).
    timeout : float, optional
        Wall-clock seconds for the whole packing (loading and analysis included). Every solve gets at most
        the time left, and a solver that overruns it (ignoring its limit, or having none) is stopped with
        its worker process after a short allowance (`harness.late_allowance`); once it is
        spent, the sequence stops, the expressions found so far are written, and a warning says so. When no
        expression was found by then, an error says so and nothing is written.
    force : bool
        Replace an earlier packing in ``out`` (a folder holding anything else is refused).
    rejections : mapping
        1-based expression number -> shapes the artist rejects there (sec. 4.5.3), primary or extra.
    inputs : tuple of Path
        Further input files (e.g. a constraints file) the output folder must stay apart from; the rig, the
        target and a regions file are always.
    minimum : bool
        The fewest expressions that cover every shape, in importance order, instead of Algorithm 1.
    pictures : bool
        Render the pictures of every expression.
    glb : bool
        Also write ``expressions.glb``.
    exclude : tuple of str
        Shapes left out of the whole session.
    default_constraints : bool
        Apply the anatomical rules shipped with `packing` to the shapes whose names match
        (`session._constraints`).
    """

    rig: str
    solver: str
    out: Path
    params: Mapping[str, Any] = field(default_factory=dict)
    jmax: int | None = None
    target: str | None = None
    seed: int = 0
    time_limit: float | None = None
    timeout: float | None = None
    force: bool = False
    rejections: Mapping[int, set[str]] = field(default_factory=dict)
    inputs: tuple[Path, ...] = ()
    minimum: bool = False
    pictures: bool = True
    glb: bool = False
    exclude: tuple[str, ...] = ()
    default_constraints: bool = True


def check_minimum(
    minimum: bool, *, refining: bool, extra_examples: bool, timeout: float | None, given: Collection[str] = ()
) -> None:
    """Refuse a ``minimum`` packing with what it cannot honour: refinement (``refining``: prompts or
    rejections), extra examples, a ``timeout``, or an option ``given`` on the command line that it would
    silently ignore (``--jmax``, ``--solver``, even at its default value).

    Raises
    ------
    registry.HarnessError
        Naming every option ``--minimum`` takes no part of.
    """
    if minimum and (refining or extra_examples or timeout is not None or given):
        raise HarnessError(
            "--minimum covers every shape in the fewest expressions, with CP-SAT: it takes no --jmax, "
            "--solver, --refine, --reject, --extra-examples or --timeout (use --time-limit for the proof)"
        )


def pack(config: PackConfig, *, decide: Callable[[int, str, bool], bool] | None = None) -> PackResult:
    """Pack one rig and write the session folder ``config.out`` (see the module docstring).

    Parameters
    ----------
    config : PackConfig
    decide : callable, optional
        Interactive refinement: ``decide(expression, shape, extra_example) -> accept?`` for every proposed
        shape (sec. 4.5.3).

    Raises
    ------
    registry.OutputFolderError
        For an output folder that may not be used (before any packing is done).
    registry.HarnessError
        For ``minimum`` with refinement, extra examples or a timeout (`check_minimum`), a rejection of a
        shape the rig lacks or for an expression the session does not have.
    harness.SolverFailure
        A solver that failed on an expression (it raised, answered items the problem does not have,
        claimed infeasibility, exited or crashed: it solves in a worker process), before anything is
        written.
    """
    import packing

    params, rejections = config.params, dict(config.rejections)
    check_minimum(
        config.minimum,
        refining=bool(rejections) or decide is not None,
        extra_examples=bool(params.get("extra_examples")),
        timeout=config.timeout,
    )
    check_settings([config.solver], [], solver_option="--solver")
    started = monotonic()
    with ExitStack() as held:  # the output folder's lock, once it is claimed
        with (
            nullcontext() if config.minimum else IsolatedSolver(config.solver) as isolated
        ):  # starts while loading
            full_rig, target_mesh, read_notes = _read_inputs(config)
            for name in sorted({name for names in (rejections or {}).values() for name in names}):
                full_rig.index(name)  # RigError names the rig, the shape and close matches
            if rejections and config.jmax is not None and max(rejections) > config.jmax:
                raise HarnessError(_no_expression(max(rejections), rejections, f"--jmax {config.jmax}"))
            constraints = session_constraints(
                full_rig, params, exclude=config.exclude, default=config.default_constraints
            )
            rig, params = constraints.rig, constraints.params
            rejections = {
                number: kept
                for number, names in (rejections or {}).items()
                if (kept := names & set(rig.names))
            }
            target_vertices = None if target_mesh is None else target_mesh.vertices
            pipeline = packing.Pipeline.analyse(rig, target_vertices, **params)  # no target: among the notes
            analysis = pipeline.analysis
            scene = (
                prepare_scene(rig, analysis.params.mu) if config.pictures else None
            )  # while the solver works
            regions = params.get("regions")
            protect = [*rigs.argument_paths(config.rig), *config.inputs]
            protect += [Path(path) for path in (config.target, regions) if isinstance(path, str | PathLike)]
            folder = held.enter_context(
                claim(config.out, kind="pack", force=config.force, protect=protect, lock=True)
            )
            deadline = None if config.timeout is None else Deadline(isolated, started + config.timeout)
            rejected: dict[int, set[str]] = {}  # filled as the artist decides
            found: list[str] = list(read_notes)
            if config.minimum:
                result = minimum_sequence(analysis, time_limit=config.time_limit, seed=config.seed)
                expressions = result.expressions
                overlap = 0.0
                if not result.proven:
                    found.append(result.message())
            else:
                refining = _refining(deadline or isolated, rig, rejections, decide, rejected)
                expressions = pipeline.sequence(
                    LoudSolver(refining, config.solver),
                    jmax=config.jmax,
                    time_limit=config.time_limit,
                    seed=config.seed,
                )
                overlap = isolated.capabilities.max_overlap
        pipeline.check(expressions, overlap=overlap, maximal=not config.minimum, rejected=rejected)
        timed_out = deadline is not None and deadline.expired
        refined = bool(rejections) or decide is not None
        missing, reason = _coverage(analysis, expressions, refined, config.timeout if timed_out else None)
        if rejections and not timed_out and max(rejections) > len(expressions):
            made = f"the sequence stopped after {len(expressions)} expressions"
            raise HarnessError(_no_expression(max(rejections), rejections, made))
        notes = [*constraints.notes, *analysis.notes, _symmetry_note(analysis)]
        if config.minimum:
            notes.append(result.message())
        if missing:
            notes.append(f"{len(missing)} blendshapes in no expression ({reason}): {', '.join(missing)}")
        first = expressions[0].solution if expressions else None
        expressions = [expression for expression in expressions if expression.shapes]  # nothing to scan
        if timed_out and not expressions:
            raise HarnessError(
                f"--timeout {format_duration(config.timeout)} ran out before the first expression was found "
                f"(loading and analysing {config.rig} took {format_duration(deadline.started - started)}); "
                "give a longer --timeout"
            )
        if not expressions and first is not None and analysis.packable.any() and not refined:
            said = f": {first.message}" if first.message else ""
            raise HarnessError(
                f"solver {config.solver} found no expression for {config.rig} (its first answer: "
                f"{first.termination.value}, no blendshape{said}); nothing to scan is written"
            )
        groups = [[*expression.shapes, *expression.extra_examples] for expression in expressions]
        found += [cancellation.message for cancellation in packing.find_cancellations(rig, groups)]
        if timed_out:
            found.append(
                f"stopped by --timeout {format_duration(config.timeout)} after {len(expressions)} "
                "expressions; the expressions found so far are written"
            )
        chosen = analysis.params.as_dict()
        sequence: dict[str, Any] = {
            "mode": "minimum" if config.minimum else "sequence",
            "jmax": None if config.minimum else config.jmax,
            "seed": config.seed,
            "time_limit": result.time_limit if config.minimum else config.time_limit,
            "timeout": config.timeout,
            "overlap": overlap,
        }
        if config.minimum:
            sequence["minimum"] = result.summary()
        document = {
            "rig": config.rig,
            "solver": "cpsat" if config.minimum else config.solver,
            "params": {key: chosen[key] for key in DOCUMENT_PARAMS},
            "sequence": sequence,
            "target": None if config.target is None else str(config.target),
            "pairs": [list(pair) for pair in analysis.pairs],
            "expressions": [
                {
                    "shapes": [str(name) for name in expression.shapes],
                    "extra_examples": [str(name) for name in expression.extra_examples],
                    "objective": float(expression.objective),
                    "status": str(expression.status),
                }
                for expression in expressions
            ],
            "excluded": _excluded(analysis, missing, reason, rejected, constraints.excluded, full_rig.names),
            "constraints": constraints.document,
            "warnings": found,
        }
        session = session_files(
            rig,
            document,
            target=target_mesh,
            pictures=config.pictures,
            glb=config.glb,
            notes=[*notes, *found],
            scene=scene,
        )
        files = _write(folder, document, session)
    return PackResult(document, files, notes, found[len(read_notes) :])


class Deadline:
    """A solver wrapper that gives every solve at most the time left before a wall-clock deadline.

    Once the deadline has passed, `solve` returns no items with ``Termination.TIME_LIMIT`` without calling
    the solver, so the expression sequence (Algorithm 1) stops there; ``expired`` tells that it did (or
    that a solve was cut by the time left).

    Parameters
    ----------
    inner : Solver
    end : float
        The deadline on the ``time.monotonic`` clock.
    """

    def __init__(self, inner: IsolatedSolver, end: float) -> None:
        self.inner = inner
        self.name = inner.name
        self.capabilities = inner.capabilities
        self.end = end
        self.started = monotonic()
        self.expired = False

    def availability(self) -> Availability:
        """The inner solver's availability."""
        return self.inner.availability()

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Solution:
        """The inner solve with ``time_limit`` reduced to the time left, or nothing once it is spent."""
        from packing import Termination

        left = self.end - monotonic()
        if left <= 0:
            self.expired = True
            return no_answer(self.name, Termination.TIME_LIMIT, "the --timeout of the whole packing ran out")
        limited = time_limit is None or left < time_limit
        solution = self.inner.solve(problem, time_limit=left if limited else time_limit, seed=seed)
        if limited and solution.termination is Termination.TIME_LIMIT:
            self.expired = True
        return solution


def _coverage(
    analysis: Analysis, expressions: Sequence[Expression], refined: bool, timeout: float | None
) -> tuple[list[str], str]:
    """The packable shapes no expression holds, and why the sequence stopped before them: ``timeout``
    (seconds) ran out, an expression came out empty (every proposal rejected, or the solver found nothing),
    else ``jmax`` was reached."""
    used = {name for expression in expressions for name in expression.shapes}
    missing = [
        name
        for name, ok in zip(analysis.rig.names, analysis.packable, strict=True)
        if ok and name not in used
    ]
    if not missing:
        return [], ""
    empty = next((expression for expression in expressions if not expression.shapes), None)
    if timeout is not None:
        reason = f"--timeout {format_duration(timeout)} ran out"
    elif empty is None:
        reason = f"--jmax {len(expressions)} reached"
    elif refined:
        reason = (
            f"every shape proposed for expression {empty.index} was rejected, so the sequence stopped there"
        )
    else:
        reason = (
            f"the solver found no expression {empty.index}: {empty.status}, {empty.message or 'no message'}"
        )
    return missing, reason


def _no_expression(number: int, rejections: Mapping[int, set[str]], limit: str) -> str:
    """The error for a rejection in an expression the session cannot have."""
    return f"--reject {number}:{','.join(sorted(rejections[number]))}: no expression {number} ({limit})"


def _excluded(
    analysis: Analysis,
    missing: Sequence[str],
    reason: str,
    rejected: Mapping[int, set[str]],
    left_out: Mapping[str, str],
    names: Sequence[str],
) -> list[dict[str, str]]:
    """``excluded`` of ``expressions.json``: every shape in no expression, with the reason, in the order of
    the rig's ``names`` (those of the shapes ``left_out`` of the session included)."""
    why = dict(left_out)
    empty = "empty: no displacement above the noise floor (sec. 4.1)"
    why.update((name, empty) for name in analysis.empty_names)
    for name in missing:
        refused = sorted(number for number, names in rejected.items() if name in names)
        rejections = (
            f"; rejected by the artist for expression {', '.join(map(str, refused))}" if refused else ""
        )
        why[name] = f"in no expression: {reason}{rejections}"
    return [{"shape": name, "reason": why[name]} for name in names if name in why]


def _symmetry_note(analysis: Analysis) -> str:
    symmetry = analysis.symmetry
    if not analysis.params.symmetry:
        return "symmetry off: no pairs"
    return (
        f"{len(symmetry.pairs)} symmetry pairs kept together "
        f"({len(symmetry.shape_pairs)} mirror, {len(symmetry.motion_pairs)} motion)"
    )


def _read_inputs(config: PackConfig) -> tuple[Rig, TargetMesh | None, list[str]]:
    """The rig and the target of ``config``, and what their readers warned (`rigs.RigWarning`: a neutral out
    of line with its shapes, identical shapes, ...): shown as they come, and kept for the session's
    ``warnings``, the sheet the TD hands on."""
    from rigs import RigWarning

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rig = rigs.resolve(config.rig, seed=config.seed)
        target = read_target(config.target, rig)
    for warning in caught:
        warnings.warn_explicit(warning.message, warning.category, warning.filename, warning.lineno)
    said = [str(warning.message) for warning in caught if issubclass(warning.category, RigWarning)]
    return rig, target, said


def _refining(
    solver: IsolatedSolver | Deadline,
    rig: Rig,
    rejections: Mapping[int, set[str]],
    decide: Callable[[int, str, bool], bool] | None,
    rejected: dict[int, set[str]],
) -> IsolatedSolver | Deadline | RefiningSolver:
    """Wrap the solver in `solvers.RefiningSolver` (sec. 4.5.3) when there is anything to decide; every
    rejection lands in ``rejected`` (1-based expression -> shapes) for the checker."""
    if not rejections and decide is None:
        return solver
    import solvers

    listed = solvers.rejecting({expression - 1: names for expression, names in rejections.items()})

    def accept(proposal: Proposal) -> bool:
        keep = listed(proposal) and (
            decide is None or decide(proposal.expression + 1, proposal.label, proposal.extra_example)
        )
        if not keep:
            rejected.setdefault(proposal.expression + 1, set()).update(proposal.shapes)
        return keep

    return solvers.RefiningSolver(solver, accept)


def _write(
    folder: OutputFolder, document: dict[str, Any], session: Iterable[tuple[str, str | bytes]]
) -> list[Path]:
    """Write the session's files and ``expressions.json`` (made once the others have filled in its
    ``files``) as the claimed folder's whole content (all or none). Returns the files, JSON first."""

    def contents() -> Iterator[tuple[str, str | bytes]]:
        yield from session
        yield EXPRESSIONS_FILE, json.dumps(document, indent=2) + "\n"

    paths = folder.replace(contents())
    paths.insert(0, paths.pop())
    return paths
