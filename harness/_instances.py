"""``harness instances export``: the subproblems of reference sequences as MPS files with a MIPLIB ``.solu``.

Sequences of different solvers diverge after the first expression, so to compare solvers (ours or outside
tools) on the same problems, one reference sequence (Algorithm 1, one exact solver) is frozen and each of its
subproblems is written as the model the exact backends solve (docs/architecture.md, "Common instances").
``DIR`` holds:

``PREFIX-eXX.mps``
    Expression XX's presolved model (eq. 3 after presolve, sec. 6), written as the minimisation of
    ``-sum_i w_i x_i`` over binary x (every MPS reader minimises by default; PuLP's CBC ignores an
    ``OBJSENSE MAX`` section), one row ``sum_{i in C} x_i <= 1`` (``cR``) per maximal conflict set C (apart
    pairs among them) and the cap row (``cap``) when a cap can bind, written by HiGHS from
    `solvers.CliqueModel` (`solvers.write_mps`: free MPS, coefficients with 15 significant digits). The
    weights are
    the problem's: the importance of eq. 4 plus the exact backends' tie-break (at most 1e-5 per item). This
    is the whole subproblem of the expression, before the exact reductions (`solvers._reduce`) a backend
    applies to it, so its optimum is the expression's.
``instances.solu``
    One MIPLIB line per instance, in file order: ``=opt=  NAME  VALUE`` when the reference solver proved
    optimality, ``=best= NAME VALUE`` when it stopped at its time limit (or is a heuristic), ``=inf=  NAME``
    for an infeasible one and ``=unkn= NAME`` when it found nothing (an error). VALUE is the objective of
    the MPS file as written (its coefficients as read back) at the reference packing, 17 significant digits,
    in the file's own (minimisation) sense: minus the packing's importance sum.
``instances.json``
    ``{"format": "harness-instances", "version": 1, "solver": str, "sequences": [...], "instances": [...]}``;
    each sequence is `harness._instances_source.Sequence.describe` plus ``expressions`` (how many); each
    instance has ``name``, ``file``, ``sequence`` (its prefix), ``rig``, ``warp``, ``expression`` (1-based),
    ``items``, ``clique_rows``, ``cap`` (the cap row's right-hand side or null), ``solver``, ``termination``,
    ``status`` (the ``.solu`` one), ``value`` (as in ``.solu``; null for ``inf``/``unkn``), ``objective``
    (the importance sum of eq. 3a, without tie-break), ``bound``, ``solve_time``, ``chosen`` (column names
    of the reference packing) and ``columns`` (column name -> the rig's shape names in that item: two for a
    symmetry or together pair). Columns are named after their items (``jawOpen``,
    ``eyeBlink_L+eyeBlink_R``) when every name of the instance is a safe MPS name, else ``x0``, ``x1``, ...

The folder is claimed with `registry.claim` (kind ``instances``) as ``harness pack`` claims its: an earlier
export is replaced only with ``force``, a folder holding anything else is refused, every file is listed in
the manifest, and the export is written beside the folder and renamed into its place as a whole.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from harness._instances_source import Sequence
from registry import HarnessError, claim

if TYPE_CHECKING:
    import numpy as np

    from harness._isolated import IsolatedSolver
    from packing import Expression, PackingProblem, Pipeline, Solution, Termination
    from rigs import Rig
    from solvers import LoadedSolver

SOLU_FILE = "instances.solu"
INDEX_FILE = "instances.json"
FORMAT = "harness-instances"
VERSION = 1


@dataclass(frozen=True)
class ExportResult:
    """What `export` wrote: the ``instances.json`` document and the files (MPS files, then the ``.solu``
    and the JSON)."""

    document: dict[str, Any]
    files: list[Path]


class Recorder:
    """A solver wrapper that keeps every primary subproblem (Algorithm 1's, not the second pass of sec. 6)
    with the solver's answer, in order."""

    def __init__(self, inner: LoadedSolver) -> None:
        self.inner = inner
        self.name = inner.name
        self.capabilities = inner.capabilities
        self.solved: list[tuple[PackingProblem, Solution]] = []

    def availability(self):
        """The inner solver's availability."""
        return self.inner.availability()

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Solution:
        """The inner solve, recorded."""
        solution = self.inner.solve(problem, time_limit=time_limit, seed=seed)
        if problem.meta.get("stage", "primary") == "primary":
            self.solved.append((problem, solution))
        return solution


def solu_status(termination: Termination, found: bool) -> str:
    """The ``.solu`` status of a reference answer: ``opt`` when proved optimal, ``inf`` when proved
    infeasible, ``best`` for any other answer with a packing (a time limit, a heuristic's), else ``unkn``."""
    from packing import Termination

    if termination is Termination.OPTIMAL:
        return "opt"
    if termination is Termination.INFEASIBLE:
        return "inf"
    return "best" if found else "unkn"


def export(
    sequences: Iterable[Sequence], *, solver: LoadedSolver | IsolatedSolver, out: Path, force: bool = False
) -> ExportResult:
    """Run every reference sequence with ``solver`` and write its subproblems to ``out`` (module notes).

    Parameters
    ----------
    sequences : iterable of Sequence
        What to replay (`harness._instances_source.from_rig` / ``from_run``).
    solver : LoadedSolver or IsolatedSolver
        The reference solver (``solvers.get(name)``, or one solving in a worker process; an exact one proves
        the ``=opt=`` values).
    out : Path
        Output folder (created; see the module notes for what it may already hold).
    force : bool
        Replace an earlier export.

    Raises
    ------
    registry.OutputFolderError
        For an output folder that may not be used (checked before any solve).
    ValueError
        For bad packing parameters, or a reference sequence the independent checker refutes.
    """
    sequences = _unique_prefixes(list(sequences))
    protect = [path for sequence in sequences for path in sequence.inputs]
    with claim(out, kind="instances", force=force, protect=protect, lock=True) as folder:
        described, instances, files = [], [], []
        for sequence in sequences:
            solved = recorded_sequence(
                sequence.rig,
                sequence.target_neutral,
                solver,
                params=dict(sequence.params),
                jmax=sequence.jmax,
                time_limit=sequence.time_limit,
                seed=sequence.seed,
            ).solved
            described.append({**sequence.describe(), "expressions": len(solved)})
            for problem, solution in solved:
                entry, text = _instance(sequence, problem, solution)
                instances.append(entry)
                files.append((entry["file"], text))
        from solvers import solu_line

        solu = "".join(
            solu_line(entry["status"], entry["name"], entry["value"]) + "\n" for entry in instances
        )
        document = {
            "format": FORMAT,
            "version": VERSION,
            "solver": solver.name,
            "sequences": described,
            "instances": instances,
        }

        def contents() -> Iterator[tuple[str, str]]:
            yield from files
            yield SOLU_FILE, solu
            yield INDEX_FILE, json.dumps(document, indent=2) + "\n"

        return ExportResult(document, folder.replace(contents()))


@dataclass(frozen=True)
class RecordedSequence:
    """A reference sequence (Algorithm 1 with one solver, checked: its `packing.Pipeline`) and the primary
    subproblems it solved, each with the solver's answer, in order."""

    pipeline: Pipeline
    expressions: list[Expression]
    solved: list[tuple[PackingProblem, Solution]]


def recorded_sequence(
    rig: Rig,
    target_neutral: np.ndarray | None,
    solver: LoadedSolver,
    *,
    params: dict[str, Any],
    jmax: int | None,
    time_limit: float | None,
    seed: int,
) -> RecordedSequence:
    """Algorithm 1 on ``rig`` with ``solver``, checked by `packing.check` with maximality, every primary
    subproblem recorded (what ``harness instances export`` writes and ``harness run --replay`` solves).

    Raises
    ------
    registry.HarnessError
        When the solver reports an error in some expression (naming it).
    packing.CheckError
        When the sequence fails the independent check.
    """
    import packing

    recorder = Recorder(solver)
    pipeline = packing.Pipeline.analyse(rig, target_neutral, **params)
    expressions = pipeline.sequence(recorder, jmax=jmax, time_limit=time_limit, seed=seed)
    failed = packing.failed_expression(expressions)
    if failed is not None:
        reason = [line for line in str(failed.message).splitlines() if line.strip()]
        raise HarnessError(
            f"reference solver {solver.name} failed in expression {failed.index}"
            + (f": {reason[-1].strip()}" if reason else "")
        )
    pipeline.check(expressions, overlap=solver.capabilities.max_overlap)
    return RecordedSequence(pipeline, expressions, recorder.solved)


def _instance(sequence: Sequence, problem: PackingProblem, solution: Solution) -> tuple[dict[str, Any], str]:
    """The ``instances.json`` entry and the MPS text of one expression's subproblem."""
    import solvers

    index = int(problem.meta["expression"])
    name = f"{sequence.prefix}-e{index:02d}"
    model = solvers.CliqueModel.from_problem(problem)
    columns = solvers.column_names([problem.item_label(i) for i in range(problem.n_items)])
    mps = solvers.write_mps(model, name=name, columns=columns)
    items = [int(i) for i in solution.items]
    status = solu_status(solution.termination, bool(items) or problem.n_items == 0)
    value = mps.objective(items) if status in ("opt", "best") else None
    entry = {
        "name": name,
        "file": f"{name}.mps",
        "sequence": sequence.prefix,
        "rig": sequence.rig_argument,
        "warp": sequence.warp,
        "expression": index,
        "items": model.n_items,
        "clique_rows": model.n_rows,
        "cap": model.cap,
        "solver": solution.backend,
        "termination": str(solution.termination),
        "status": status,
        "value": value,
        "objective": float(solution.objective),
        "bound": solution.bound,
        "solve_time": float(solution.solve_time),
        "chosen": [columns[i] for i in items],
        "columns": {
            column: [problem.shape_names[k] for k in problem.items[i]] for i, column in enumerate(columns)
        },
    }
    return entry, mps.text


def _unique_prefixes(sequences: list[Sequence]) -> list[Sequence]:
    """The sequences with prefixes made distinct (``face``, ``face-2``, ...: two rig files of one stem)."""
    from dataclasses import replace

    seen: dict[str, int] = {}
    unique = []
    for sequence in sequences:
        count = seen.get(sequence.prefix, 0) + 1
        seen[sequence.prefix] = count
        unique.append(sequence if count == 1 else replace(sequence, prefix=f"{sequence.prefix}-{count}"))
    return unique
