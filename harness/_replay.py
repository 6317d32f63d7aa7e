"""Replay cells (``harness run --replay``): every solver timed on the subproblems of one reference sequence.

Sequences of different solvers part ways after the first expression, so their times are on different
problems. A ``replay`` cell instead solves, with its own solver, each subproblem of one reference sequence:
Algorithm 1 with `REFERENCE_SOLVER` (exact), the cell's rig, warp and packing settings, ``jmax`` and time
limit, solver seed `REFERENCE_SEED`, checked by `packing.check` with maximality (as ``harness instances
export`` freezes one, `harness._instances.recorded_sequence`). The reference is computed once per
worker process and group (`reference`) and shared by the replay cells of every
solver, repetition and permutation.

A replay cell records one ``expression`` row per instance (``expression`` is the instance's index in the
reference): the objective, termination, bound, times and shapes of *its* solver's answer, the instance's
size, ``presolve_time`` 0 (the instance is given). It has no transfers. Its answers are checked one by one
(`Reference.check`): each must be valid on its own instance (overlap within the solver's declared
``max_overlap``, the cap, symmetry and artist pairs, a bound at least the objective) and, for a solver that
ran to its end, maximal among the instance's items.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Hashable, Iterable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

import packing
from harness import _plugins as plugins
from harness._grid import NO_WARP, CellSpec
from harness._instances import recorded_sequence
from harness._rows import sequence_facts
from packing import Expression, Termination
from registry import HarnessError

if TYPE_CHECKING:
    from packing import PackingProblem, Pipeline
    from rigs import Rig
    from solvers import LoadedSolver

#: The exact solver whose sequence every replay cell solves.
REFERENCE_SOLVER = "cpsat"
#: Solver seed of the reference sequence (the same for every repetition, so they share it).
REFERENCE_SEED = 0

_MEMO_SIZE = 4
_lock = threading.Lock()
_references: OrderedDict[Hashable, Reference] = OrderedDict()


@dataclass(frozen=True)
class Reference:
    """One reference sequence: its pipeline (the analysis, the seconds it took, the checker's parameters)
    and its instances in order, each with the shapes the reference used before it (those its problem no
    longer holds)."""

    pipeline: Pipeline
    instances: tuple[PackingProblem, ...]
    used_before: tuple[frozenset[str], ...]

    def check(self, answers: Iterable[Any], *, overlap: float) -> None:
        """Check every answer on its own instance (`packing.Pipeline.check` of the one expression): valid
        with the reference's symmetry pairs and the solver's declared ``overlap``, and maximal where the
        solver ran to its end, the shapes the reference used before the instance not counted as fitting.

        Raises
        ------
        ValueError
            For an answer that names no instance of the reference.
        packing.CheckError
            For the first answer that breaks a rule, naming its instance.
        """
        for answer in answers:
            index = int(answer.index)
            if not 1 <= index <= len(self.instances):
                raise ValueError(f"instance {index} is not one of the reference's 1..{len(self.instances)}")
            try:
                self.pipeline.check([answer], overlap=overlap, rejected={1: self.used_before[index - 1]})
            except packing.CheckError as error:
                message = str(error).split(": ", 1)[-1]
                raise packing.CheckError(f"(instance) {message}", kind=error.kind, expression=index) from None


def reference(spec: CellSpec, template: Rig, target: Rig, params: Mapping[str, Any]) -> Reference:
    """The reference sequence of a cell's group, computed on first use in this process.

    Raises
    ------
    packing.CheckError
        When the reference sequence fails the independent check.
    registry.HarnessError
        When the reference solver reports an error.
    """
    key = (
        spec.rig, spec.rig_digest, spec.rig_seed, spec.warp, spec.jmax, spec.time_limit,
        repr(sorted((name, repr(value)) for name, value in params.items())),
    )  # fmt: skip
    with _lock:
        if key in _references:
            _references.move_to_end(key)
            return _references[key]
    found = _build(spec, template, target, params)
    with _lock:
        _references[key] = found
        while len(_references) > _MEMO_SIZE:
            _references.popitem(last=False)
    return found


def _build(spec: CellSpec, template: Rig, target: Rig, params: Mapping[str, Any]) -> Reference:
    """Algorithm 1 with `REFERENCE_SOLVER`, checked with maximality, and its recorded subproblems."""
    recorded = recorded_sequence(
        template,
        None if spec.warp == NO_WARP else target.neutral,
        plugins.load_solver(REFERENCE_SOLVER),
        params=dict(params),
        jmax=spec.jmax,
        time_limit=spec.time_limit,
        seed=REFERENCE_SEED,
    )
    used: list[frozenset[str]] = []
    for expression in recorded.expressions:
        used.append(frozenset(expression.shapes).union(*used[-1:]))
    return Reference(
        pipeline=recorded.pipeline,
        instances=tuple(problem for problem, _ in recorded.solved),
        used_before=(frozenset(), *used[:-1]),
    )


def pack(
    spec: CellSpec, solver: LoadedSolver, template: Rig, target: Rig, params: Mapping[str, Any]
) -> tuple[Reference, list[Expression], dict[str, Any]]:
    """The cell's reference, one expression per reference instance solved by the cell's solver (up to the
    first that fails), and the cell facts (of the reference's analysis)."""
    found = reference(spec, template, target, params)
    expressions = []
    for problem in found.instances:
        expressions.append(_solve(problem, solver, spec))
        if expressions[-1].termination is Termination.ERROR:
            break
    return found, expressions, sequence_facts(found.pipeline, expressions)


def _solve(problem: PackingProblem, solver: LoadedSolver, spec: CellSpec) -> Expression:
    """One instance solved by the cell's solver, as the expression `packing.sequence` would record."""
    solution = solver.solve(problem, time_limit=spec.time_limit, seed=spec.seed)
    chosen = np.array(sorted({int(item) for item in solution.items}), dtype=np.int64)
    if chosen.size and (chosen[0] < 0 or chosen[-1] >= problem.n_items):
        raise HarnessError(
            f"solver {solution.backend or '?'} returned items {list(solution.items)} "
            f"outside 0..{problem.n_items - 1}"
        )
    return Expression(
        index=int(problem.meta["expression"]),
        shapes=problem.shapes_of(chosen),
        items=tuple(problem.item_label(i) for i in chosen),
        objective=problem.unperturbed_objective(chosen),
        solution=solution,
        presolve_time=0.0,
        n_items=problem.n_items,
        vertex_rows=problem.n_vertex_rows,
        clique_rows=len(problem.cliques),
    )
