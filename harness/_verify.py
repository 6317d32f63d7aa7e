"""The harness's own check of every cell's answer, in its own process, before the cell is recorded.

A cell runs in a worker process (`harness._executors`), where its solver plugin runs too, and a plugin can
change anything in its own process: the worker's check (`harness._cell`) is no proof. So the run re-checks
what each worker returned here, in the process that writes the records, with `packing.Pipeline.check` on the
rig as this process reads it (`harness._cell_rigs.verified_template`), the symmetry pairs of this process's
own analysis, the overlap the solver declares (``capabilities.max_overlap`` of the cell's solver made here
with its settings), the cell's packing parameters, bounds at least the objectives, no infeasible verdict, and
maximality where the solver ran to its end. A replay cell's answers are checked one by one on their own
instances, as `harness._replay.Reference.check` does, with the reference sequence computed here. A cell whose
rows fail is recorded ``invalid`` (the cell row alone, as a failed check in the worker gives), and so is one
whose rows are not a cell's records at all.

What is expensive is kept per rig and setting (`CellChecker`): the rigs, their analysis and the replay
reference are built once for the cells that share them.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from types import SimpleNamespace
from typing import TYPE_CHECKING, Any

from harness import _plugins as plugins, _replay
from harness._cell import failure_rows
from harness._cell_rigs import packing_params, rig_pair
from harness._grid import NO_WARP, CellSpec
from harness._rows import Row
from registry import BoundedMemo

if TYPE_CHECKING:
    from packing import Pipeline

#: The ``kind`` of the row every cell's records start with.
CELL_KIND = "cell"
#: Row values copied from the worker's cell row into the ``invalid`` row that replaces its records.
_KEPT = ("n_vertices", "n_shapes", "worker", "cell_time")


class CellChecker:
    """Checks the rows of finished cells in this process (module notes), keeping what cells share.

    Call it with a cell and the rows its worker returned; it returns the rows to record: the same rows
    (their identifying columns set from the cell itself), or the cell's ``invalid`` row.
    """

    def __init__(self) -> None:
        self._pipelines: BoundedMemo[Pipeline] = BoundedMemo(8)
        self._overlaps: dict[str, float] = {}

    def __call__(self, spec: CellSpec, rows: object) -> list[Row]:
        problem = _malformed(rows)
        if problem:
            return _invalid(spec, {}, f"the worker's rows are not a cell's records: {problem}")
        assert isinstance(rows, list)
        identity = spec.record_fields()
        rows = [{**row, **identity} for row in rows]
        if rows[0].get("status") != "ok":
            return rows
        try:
            self._check(spec, rows)
        except Exception as error:  # noqa: BLE001 - CheckError, and rows the checker cannot read
            return _invalid(spec, rows[0], f"{type(error).__name__}: {_first_line(error)}")
        return rows

    def _check(self, spec: CellSpec, rows: list[Row]) -> None:
        """Raise `packing.CheckError` (or another exception) when the cell's answer breaks a rule."""

        expressions = sorted(
            (row for row in rows if row.get("kind") == "expression"), key=lambda row: _number(row)
        )
        counted = rows[0].get("n_expressions")
        if spec.mode != "replay" and counted is not None and counted != len(expressions):
            raise ValueError(f"the cell row counts {counted} expressions, its rows hold {len(expressions)}")
        template, target = rig_pair(spec)
        params = packing_params(spec)
        overlap = self._overlap(spec.solver)
        answers = [_expression(row) for row in expressions]
        if spec.mode == "replay":
            _replay.reference(spec, template, target, params).check(answers, overlap=overlap)
            return
        self._pipeline(spec, template, target, params).check(answers, overlap=overlap)

    def _pipeline(self, spec: CellSpec, template: Any, target: Any, params: Mapping[str, Any]) -> Pipeline:
        """The analysis the cell's sequence is checked against (its symmetry pairs), once per rig and
        setting."""
        import packing

        key = (
            spec.rig, spec.rig_digest, spec.rig_seed, spec.warp, spec.mu, spec.alpha, spec.beta,
            spec.symmetry, spec.importance, spec.cap, spec.distortion, spec.together, spec.apart,
            spec.regions,
        )  # fmt: skip

        def build() -> Pipeline:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                neutral = None if spec.warp == NO_WARP else target.neutral
                return packing.Pipeline.analyse(template, neutral, **params)

        return self._pipelines.get_or_build(key, build)

    def _overlap(self, label: str) -> float:
        """The overlap the cell's solver declares, made here with its settings."""
        if label not in self._overlaps:
            self._overlaps[label] = float(plugins.solver_capabilities(label).max_overlap)
        return self._overlaps[label]


def _malformed(rows: object) -> str:
    """What makes ``rows`` no cell's records ("" when they are a list of rows, the cell row first)."""
    if not isinstance(rows, list) or not rows:
        return f"expected a list of rows, got {type(rows).__name__}"
    if not all(isinstance(row, dict) for row in rows):
        return "a row is not a mapping"
    kinds = [row.get("kind") for row in rows]
    if kinds[0] != CELL_KIND or kinds.count(CELL_KIND) != 1:
        return "one cell row first, then the cell's other rows"
    return ""


def _number(row: Row) -> int:
    number = row.get("expression")
    if isinstance(number, bool) or not isinstance(number, int):
        raise ValueError(f"an expression row has no expression number ({number!r})")
    return number


def _expression(row: Row) -> SimpleNamespace:
    """What `packing.check` reads of an ``expression`` row."""
    return SimpleNamespace(
        index=_number(row),
        shapes=tuple(row.get("shapes") or ()),
        extra_examples=tuple(row.get("extra_examples") or ()),
        objective=row.get("objective"),
        bound=row.get("bound"),
        termination=row.get("termination"),
    )


def _invalid(spec: CellSpec, cell_row: Mapping[str, object], message: str) -> list[Row]:
    """The cell's ``invalid`` row, keeping what the worker measured of the cell (`_KEPT`)."""
    (row,) = failure_rows(spec, "invalid", f"the harness's check: {message}")
    row.update({key: cell_row[key] for key in _KEPT if cell_row.get(key) is not None})
    return [row]


def _first_line(error: BaseException) -> str:
    lines = str(error).strip().splitlines()
    return lines[0] if lines else ""
