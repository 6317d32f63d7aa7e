"""One grid cell, run inside a worker: build the rigs, pack, verify, transfer, and return record rows.

A ``replay`` cell (`harness._replay`) solves the instances of a reference sequence instead of packing its
own, and has no transfers; a cell of permutation p > 0 gives its solver every problem with the items
shuffled (`harness._permute`).

Everything numerical is delegated: `rigs` builds and warps the rig, `packing.Pipeline` analyses it, runs
Algorithm 1 with the cell's solver and re-verifies the sequence from the raw deltas, and `transfer` methods
rebuild the target's blendshapes from the first J expressions, trained on the cell's examples
(`harness._grid.EXAMPLES`: scan-like captures of the target, seeded by the cell's seed, or its ideal
linear sums; or random expressions instead of the sequence), or retarget random source frames with them
(``--frames``, `harness._animation`). This module only times the calls and turns their results into rows
of the records table (see `harness._records`).

The check trusts nothing the solver says about itself beyond its declared capabilities: the symmetry pairs
are the harness's own analysis, the overlap allowance is ``solver.capabilities.max_overlap``, a bound below
the objective is rejected, and an expression of a solver that ran to its end must be maximal.
"""

from __future__ import annotations

import datetime
import functools
import os
import socket
import time
import types
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

import packing
import solvers
from harness import _animation, _plugins as plugins, _replay
from harness._cell_rigs import RigChangedError, packing_params, rig_pair, template_rig
from harness._grid import NO_WARP, CellSpec
from harness._journal import SEQUENCE_END, append_row
from harness._permute import permuted_solver
from harness._rows import RecordValue, Row, expression_record, sequence_facts
from harness._settings import split_label
from packing import Expression
from registry import BoundedMemo

if TYPE_CHECKING:
    from packing import Analysis, Pipeline
    from rigs import Rig
    from solvers import LoadedSolver


#: Transfer errors by (rig, warp, method, examples, weights): solvers that agree share one computation.
_TRANSFERS: BoundedMemo[Row] = BoundedMemo(512)
#: Estimates (K, N, 3) of methods that ignore the training expressions, by (rig, warp, method).
_ESTIMATES: BoundedMemo[np.ndarray] = BoundedMemo(2)
_warmed_up: set[str] = set()
#: Shapes with the largest transfer error recorded per transfer row.
_WORST_SHAPES = 5


@dataclass(frozen=True)
class Lost:
    """The outcome of a cell without a result, instead of its record rows.

    Its worker process died or failed (``crash`` then says how: ``killed by SIGSEGV``, ``exit code 3``, or
    the exception it raised), the worker process did not start in time, the Dask scheduler or worker went
    away, a Dask worker could not set the cell up (`CellSetupError`), or the rig file changed under the
    run. `harness._run` writes no part file for it, so ``--resume`` runs it again; a cell whose worker
    crashed on it twice is recorded ``crashed`` instead.
    """

    reason: str
    crash: str = ""


class CellSetupError(RuntimeError):
    """A machine other than the harness's cannot set a cell up: its rig cannot be built there, or one of
    its plugins does not load there (not installed, another version)."""


def set_up(spec: CellSpec, template: Rig | None = None) -> None:
    """Build (or take) a cell's template rig and load its solver and transfer plugins, available, on a
    machine other than the harness's, before the cell runs there. What the cell itself does with them (its
    warp, its solves) is the cell's: its failures are the cell's rows.

    Raises
    ------
    CellSetupError
        Naming the machine and what failed: the cell cannot run here, which is no result of the cell.
    """
    try:
        template_rig(spec, template)
        for label, info in [
            (spec.solver, plugins.solver_info(spec.solver)),
            *((name, plugins.transfer_info(name)) for name in spec.transfers),
        ]:
            if not info.available:
                raise RuntimeError(f"{label} is unavailable here: {info.reason or 'no reason given'}")
        plugins.load_solver(spec.solver)
        for name in spec.transfers:
            plugins.transfer_method(name)
    except Exception as error:  # noqa: BLE001 - whatever fails, the cell cannot run on this machine
        raise CellSetupError(f"{_worker_name()} cannot set the cell up: {_describe(error)}") from None


def started() -> str:
    """The name of the worker process (``host:pid``): its reply to a first call says it has started and
    imported the harness."""
    return _worker_name()


def warm_up(solver_name: str, time_limit: float | None = None) -> None:
    """Warm a solver up once per process (`solvers.warm_up`, within the run's ``time_limit``), so that
    import and start-up costs stay out of every recorded timing. Failures are ignored here: the timed cell
    reports them."""
    if solver_name in _warmed_up:
        return
    _warmed_up.add(solver_name)
    try:
        solver = plugins.load_solver(solver_name)
    except (Exception, SystemExit):  # noqa: BLE001 - the timed cell reports the real failure
        return
    solvers.warm_up(solver, time_limit)


def run_cell(spec: CellSpec, journal: str | None = None, template: Rig | None = None) -> list[Row] | Lost:
    """Run one cell and return its record rows (the ``cell`` row first).

    Never raises for a failing rig, solver, check or transfer: the failure becomes the ``status`` and
    ``message`` of the rows, as the records schema describes. A rig file whose content changed since the
    run started gives `Lost` (no result for this run's cell).

    Parameters
    ----------
    spec : CellSpec
    journal : str, optional
        A file (`harness._journal`) to which each expression's row is appended as soon as the expression
        is finished, so that an executor that stops the cell still has them.
    template : Rig, optional
        The template rig's content as the harness read it (`harness._cell_rigs.verified_template`),
        instead of reading ``spec.rig`` here (a Dask worker may have no such file).
    """
    base: Row = spec.record_fields()
    cell_row: Row = {
        **base,
        "kind": "cell",
        "status": "ok",
        "message": "",
        "worker": _worker_name(),
    }
    try:
        template, target = rig_pair(spec, template)
    except RigChangedError as error:
        return Lost(str(error))
    except Exception as error:  # noqa: BLE001 - recorded, the run goes on
        return [_finish(cell_row, status="error", message=f"rig {spec.rig!r}: {_describe(error)}")]
    base.update(n_vertices=template.n_vertices, n_shapes=template.n_shapes)
    cell_row.update(n_vertices=template.n_vertices, n_shapes=template.n_shapes)

    started = time.perf_counter()

    def stop(status: str, message: str) -> list[Row]:
        return [_finish(cell_row, status=status, message=message, cell_time=time.perf_counter() - started)]

    try:
        solver = permuted_solver(plugins.load_solver(spec.solver), spec.permutation)
        finished = _ExpressionRows(base, template.n_shapes, journal)
        if spec.mode == "replay":
            found, expressions, facts = _replay.pack(spec, solver, template, target, packing_params(spec))
            check = found.check
        else:
            pipeline, expressions, facts = _pack(spec, solver, template, target, finished)
            check = pipeline.check
    except Exception as error:  # noqa: BLE001 - a solver that raises is recorded as an error
        return stop("error", _describe(error))
    # A plugin's sys.exit is its error, not the worker's (stop signals raise KeyboardInterrupt).
    except SystemExit as exit_:
        return stop("error", f"the solver called sys.exit({exit_.code!r})")
    failed = packing.failed_expression(expressions)
    if failed is not None:
        return stop("error", f"solver error in expression {failed.index}: {failed.message or 'no message'}")
    if journal is not None:
        append_row(journal, {"kind": SEQUENCE_END})
    try:
        # The harness's own analysis and the overlap the solver declares (0 for eq. 3b), and no other.
        check(expressions, overlap=solver.capabilities.max_overlap)
    except Exception as error:  # noqa: BLE001 - CheckError and anything the checker raises
        return stop("invalid", _describe(error))

    expression_rows = _expression_rows(base, expressions, template.n_shapes)
    transfer_rows = _transfer_rows(base, spec, template, target, expressions)
    cell_row.update(
        facts,
        max_overlap=float(solver.capabilities.max_overlap),
        sequence_time=float(sum(row[key] for row in expression_rows for key in packing.EXPRESSION_TIMES)),
        n_expressions=len(expressions),
        n_covered=expression_rows[-1]["covered"] if expression_rows else 0,
        cell_time=time.perf_counter() - started,
    )
    return [_finish(cell_row), *expression_rows, *transfer_rows]


def _pack(
    spec: CellSpec,
    solver: LoadedSolver,
    template: Rig,
    target: Rig,
    on_expression: Callable[[Expression], None] | None = None,
) -> tuple[Pipeline, list[Expression], Row]:
    """The cell's analysis (timed on its own; without a warp there is no target) and whole sequence
    (Algorithm 1) with the cell's solver, and the cell row's facts with the bounds on the number of
    expressions; ``on_expression`` sees each expression as soon as it is finished."""
    target_neutral = None if spec.warp == NO_WARP else target.neutral
    pipeline = packing.Pipeline.analyse(template, target_neutral, **packing_params(spec))
    expressions = pipeline.sequence(
        solver, jmax=spec.jmax, time_limit=spec.time_limit, seed=spec.seed, on_expression=on_expression
    )
    facts = {**sequence_facts(pipeline, expressions), **_minimum(spec, pipeline.analysis)}
    return pipeline, expressions, facts


def _minimum(spec: CellSpec, analysis: Analysis) -> Row:
    """The fewest expressions covering every shape, for cells whose solver declares that exact mode
    (``capabilities.minimum_cover``)."""
    name = split_label(spec.solver)[0]
    if not solvers.solver_class(name).capabilities.minimum_cover:
        return {}
    found = solvers.minimum_expressions(
        analysis.problem, solver=name, time_limit=spec.time_limit, seed=spec.seed
    )
    return {"min_expressions": found.count, "min_expressions_status": str(found.status)}


def _expression_rows(base: Row, expressions: list[Expression], n_shapes: int) -> list[Row]:
    """One row per expression (`_ExpressionRows`)."""
    rows = _ExpressionRows(base, n_shapes)
    for expression in expressions:
        rows(expression)
    return rows.rows


class _ExpressionRows:
    """The ``expression`` rows of a sequence, made one expression at a time (``rows``).

    A row is the expression's `expression_record`, with what the cell computes from the sequence
    (``n_chosen``, the shapes ``covered`` so far and their ``coverage``). With a ``journal``, each row is
    also appended to that file (`harness._journal`) as soon as it is made.
    """

    def __init__(self, base: Row, n_shapes: int, journal: str | None = None) -> None:
        self.base, self.n_shapes, self.journal = base, n_shapes, journal
        self.covered: set[str] = set()
        self.rows: list[Row] = []

    def __call__(self, expression: Expression) -> None:
        record = expression_record(expression)
        self.covered.update(record["shapes"])
        row: Row = {
            **self.base,
            "kind": "expression",
            **record,
            "n_chosen": len(record["shapes"]),
            "covered": len(self.covered),
            "coverage": len(self.covered) / self.n_shapes if self.n_shapes else 0.0,
        }
        self.rows.append(row)
        if self.journal is not None:
            append_row(self.journal, row)


def _transfer_rows(
    base: Row, spec: CellSpec, template: Rig, target: Rig, expressions: list[Expression]
) -> list[Row]:
    import transfer

    rows = []
    if spec.examples == "random":
        whole = _animation.random_examples(template, max(spec.j_values), spec.rig_seed, spec.scan_seed)
    else:
        whole = _training_weights(template, expressions)
    j_values = sorted({min(j, len(whole)) for j in spec.j_values if len(whole)})
    examples: list[np.ndarray] = []
    for name in spec.transfers:
        first = _FirstExpressions(name, template, target, whole, examples)
        for j in j_values:
            row: Row = {
                **base,
                "kind": "transfer",
                "transfer": name,
                "j": j,
                "status": "ok",
                "message": "",
            }
            clock = time.perf_counter()
            try:
                weights = whole[:j]
                if not examples:  # every J trains on the first J of the same expressions
                    examples.append(_examples(spec, target, whole))
                estimate = functools.partial(first, j)
                if spec.frames:
                    train = (weights, examples[0][:j])
                    estimate = functools.partial(_frames, name, spec, template, target, train, estimate)
                row.update(_transfer_metrics(transfer, name, spec, template, target, weights, estimate))
                row["transfer_beta"] = _balance(name, template, target, weights, examples[0][:j])
            except Exception as error:  # noqa: BLE001 - recorded, the other J values still run
                row.update(
                    status="error", message=_describe(error), transfer_time=time.perf_counter() - clock
                )
            rows.append(row)
    return rows


class _FirstExpressions:
    """A transfer method's estimates from the first J training expressions of a cell, for any J.

    One `transfer.Transfer.prefixes` is made on first use (after the cell's examples exist), so the method
    reuses its work across the J values instead of starting over for each.
    """

    def __init__(
        self, name: str, template: Rig, target: Rig, weights: np.ndarray, examples: list[np.ndarray]
    ) -> None:
        self.name, self.template, self.target = name, template, target
        self.weights, self.examples = weights, examples
        self.prefixes: Callable[[int], np.ndarray] | None = None

    def __call__(self, j: int) -> np.ndarray:
        if self.prefixes is None:
            method = plugins.transfer_method(self.name)
            self.prefixes = method.prefixes(
                self.template, self.target.neutral, self.weights, self.examples[0]
            )
        return self.prefixes(j)


def _frames(
    name: str,
    spec: CellSpec,
    template: Rig,
    target: Rig,
    train: tuple[np.ndarray, np.ndarray],
    rig_estimate: Callable[[], np.ndarray],
) -> np.ndarray:
    """The cell's source frames (`harness._animation`) retargeted by a method trained on ``train``
    (weights and examples), stacked on their truth: ``(2, F, N, 3)``."""
    frames = _animation.source_frames(template, spec.frames, spec.rig_seed)
    method = plugins.transfer_method(name)
    found = _animation.retargeted_frames(method, template, target.neutral, *train, frames, rig_estimate)
    return np.stack([found, np.tensordot(frames, target.deltas, axes=1)])


def _examples(spec: CellSpec, target: Rig, weights: np.ndarray) -> np.ndarray:
    """The training expressions of all of a cell's training weights (`harness._grid.EXAMPLES`): scan-like
    ones are seeded by the cell's scan seed, so repetitions are independent capture sessions; random ones,
    like ideal ones, are the exact sums."""
    import transfer

    if spec.examples in ("ideal", "random"):
        return transfer.training_expressions(target, weights)
    return transfer.scan_expressions(target, weights, seed=spec.scan_seed)


def _transfer_metrics(
    transfer: types.ModuleType,
    name: str,
    spec: CellSpec,
    template: Rig,
    target: Rig,
    weights: np.ndarray,
    estimate_first: Callable[[], np.ndarray],
) -> Row:
    """Errors of one transfer (``estimate_first`` computes it from the first J expressions), memoised per
    process: on (rig, warp, method, examples mode and seed, weights), so that solvers that agree on a
    sequence share one computation, and for a method that ignores the training expressions
    (``uses_examples`` False) its estimate on (rig, warp, method) alone. With ``spec.frames`` the estimate
    is the retargeted frames stacked on their truth (`_frames`) and the row records ``frames_l2``."""
    clock = time.perf_counter()
    method = plugins.transfer_method(name)
    rig_key = (spec.rig, spec.rig_digest, spec.rig_seed, spec.warp, name, spec.frames)
    session = (spec.examples, spec.scan_seed if spec.examples == "scan" else None)
    key = (*rig_key, *session, weights.shape, weights.tobytes())
    known = _TRANSFERS.get(key)
    if known is not None:
        return {**known, "transfer_reused": True, "transfer_time": time.perf_counter() - clock}
    uses_examples = getattr(method, "uses_examples", True)
    estimate = None if uses_examples else _ESTIMATES.get(rig_key)
    reused = estimate is not None
    if estimate is None:
        estimate = estimate_first()
        if not uses_examples:
            _ESTIMATES.put(rig_key, estimate)
    if spec.frames:
        result: Row = {"frames_l2": _animation.mean_vertex_error(*estimate)}
        _TRANSFERS.put(key, result)
        return {**result, "transfer_reused": reused, "transfer_time": time.perf_counter() - clock}
    found = transfer.metrics(estimate, target.deltas, weights)
    worst = found.worst(_WORST_SHAPES)
    result = {
        "rms": _finite_or_none(found.rms),
        "rms_covered": _finite_or_none(found.rms_covered),
        "rms_uncovered": _finite_or_none(found.rms_uncovered),
        "worst_shapes": [template.names[k] for k in worst],
        "worst_rms": [float(found.per_shape[k]) for k in worst],
    }
    _TRANSFERS.put(key, result)
    return {**result, "transfer_reused": reused, "transfer_time": time.perf_counter() - clock}


def _balance(
    name: str, template: Rig, target: Rig, weights: np.ndarray, examples: np.ndarray
) -> float | None:
    """The balance ``beta`` a transfer method fitted these J expressions with (Li et al. 2010, sec. 3A), for
    a method that has one (``beta_used``): the fixed value or the one it chose from the data."""
    method = plugins.transfer_method(name)
    if not hasattr(method, "beta_used"):
        return None
    return _finite_or_none(method.beta_used(template, target.neutral, weights, examples))


def _training_weights(template: Rig, expressions: list[Expression]) -> np.ndarray:
    """(J, K) 0/1 weights: every shape present in each expression (primary and extra examples)."""
    weights = np.zeros((len(expressions), template.n_shapes))
    for row, expression in zip(weights, expressions, strict=True):
        names = [*expression.shapes, *getattr(expression, "extra_examples", ())]
        row[template.indices(names)] = 1.0
    return weights


def _finite_or_none(value: float) -> float | None:
    return float(value) if np.isfinite(value) else None


def _finish(row: Row, **updates: RecordValue) -> Row:
    row.update(updates)
    row["finished"] = datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")
    return row


def _describe(error: BaseException) -> str:
    text = str(error).strip().splitlines()
    return f"{type(error).__name__}: {text[0] if text else ''}".rstrip(": ")


def _worker_name() -> str:
    return f"{socket.gethostname()}:{os.getpid()}"


def failure_rows(spec: CellSpec, status: str, message: str) -> list[Row]:
    """The single ``cell`` row recorded for a cell without results (a timeout, an unavailable solver)."""
    return [_finish({**spec.record_fields(), "kind": "cell", "status": status, "message": message})]


def timeout_rows(
    spec: CellSpec, finished: list[Row], message: str, *, timeout: float, whole: bool
) -> list[Row]:
    """The rows of a cell stopped by ``--timeout``: its ``timeout`` cell row, then the ``expression`` rows
    it had finished (read from its journal, `harness._journal`), counted in the cell row's
    ``n_expressions`` and ``n_covered``. Such a sequence was cut short: it is not checked and has no
    transfers.

    The cell row's ``cell_time`` is the ``timeout`` it exceeded, and its ``sequence_time`` is what its
    sequence is charged: the finished expressions' times when the ``whole`` sequence had ended (the stop
    came while checking or transferring), else at least the timeout, so that a timing comparison counts
    the expression it was stuck in (`reports._timing.timing_samples`) instead of a cut sequence as fast.
    """
    (cell_row,) = failure_rows(spec, "timeout", message)
    spent = sum(float(row.get(column) or 0.0) for row in finished for column in packing.EXPRESSION_TIMES)
    cell_row.update(cell_time=timeout, sequence_time=spent if whole else max(timeout, spent))
    if finished:
        cell_row.update(
            n_vertices=finished[0].get("n_vertices"),
            n_shapes=finished[0].get("n_shapes"),
            n_expressions=len(finished),
            n_covered=finished[-1].get("covered"),
        )
    return [cell_row, *finished]
