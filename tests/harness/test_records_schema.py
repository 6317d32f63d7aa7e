"""The records schema: pinned to the files written so far, and derived from `packing.Expression`."""

from __future__ import annotations

import dataclasses
import typing
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import packing
from harness import _cell, _records, _rows
from packing import Expression, Solution, Termination

_STRINGS = pa.list_(pa.string())

#: Every column of the part files written so far (`benchmarks/baseline` among them), in file order: the
#: records of earlier runs must keep reading, resuming and comparing.
PINNED_COLUMNS: list[tuple[str, pa.DataType]] = [
    ("cell", pa.string()),
    ("kind", pa.string()),
    ("rig", pa.string()),
    ("rig_seed", pa.int64()),
    ("rig_digest", pa.string()),
    ("warp", pa.string()),
    ("solver", pa.string()),
    ("mu", pa.float64()),
    ("alpha", pa.float64()),
    ("beta", pa.float64()),
    ("symmetry", pa.bool_()),
    ("importance", pa.bool_()),
    ("cap", pa.int64()),
    ("jmax", pa.int64()),
    ("time_limit", pa.float64()),
    ("repetition", pa.int64()),
    ("seed", pa.int64()),
    ("n_vertices", pa.int64()),
    ("n_shapes", pa.int64()),
    ("status", pa.string()),
    ("message", pa.string()),
    ("analysis_time", pa.float64()),
    ("sequence_time", pa.float64()),
    ("cell_time", pa.float64()),
    ("n_expressions", pa.int64()),
    ("n_covered", pa.int64()),
    ("n_pairs", pa.int64()),
    ("n_empty", pa.int64()),
    ("lower_bound", pa.int64()),
    ("min_expressions", pa.int64()),
    ("min_expressions_status", pa.string()),
    ("backend_version", pa.string()),
    ("worker", pa.string()),
    ("finished", pa.string()),
    ("expression", pa.int64()),
    ("shapes", _STRINGS),
    ("n_chosen", pa.int64()),
    ("extra_examples", _STRINGS),
    ("objective", pa.float64()),
    ("bound", pa.float64()),
    ("termination", pa.string()),
    ("presolve_time", pa.float64()),
    ("build_time", pa.float64()),
    ("solve_time", pa.float64()),
    ("extra_time", pa.float64()),
    ("n_items", pa.int64()),
    ("vertex_rows", pa.int64()),
    ("clique_rows", pa.int64()),
    ("covered", pa.int64()),
    ("coverage", pa.float64()),
    ("fallback", pa.string()),
    ("transfer", pa.string()),
    ("j", pa.int64()),
    ("rms", pa.float64()),
    ("rms_covered", pa.float64()),
    ("rms_uncovered", pa.float64()),
    ("worst_shapes", _STRINGS),
    ("worst_rms", pa.list_(pa.float64())),
    ("transfer_time", pa.float64()),
    ("transfer_reused", pa.bool_()),
]
PINNED_TIMING = (
    "analysis_time",
    "sequence_time",
    "cell_time",
    "presolve_time",
    "build_time",
    "solve_time",
    "extra_time",
    "transfer_time",
    "transfer_reused",
    "worker",
    "finished",
)
BASELINE = Path(__file__).resolve().parents[2] / "benchmarks" / "baseline"


def _expression(**changes: object) -> Expression:
    solution = Solution(
        items=(0, 2),
        shapes=("jawOpen", "smile_L", "smile_R"),
        objective=2.5,
        bound=None,
        termination=Termination.COMPLETED,
        build_time=0.25,
        solve_time=0.5,
        cpu_time=0.75,
        backend="greedy",
        version="1.0",
        message="",
    )
    fields = {
        "index": 1,
        "shapes": ("jawOpen", "smile_L", "smile_R"),
        "items": ("jawOpen", "smile_L+smile_R"),
        "objective": 2.5,
        "solution": solution,
        "presolve_time": 0.125,
        "n_items": 4,
        "vertex_rows": 30,
        "clique_rows": 3,
        **changes,
    }
    return Expression(**fields)


def test_the_columns_of_the_files_written_so_far_are_kept_with_their_types() -> None:
    columns = dict(_records.RECORD_COLUMNS.items())
    assert {name: columns.get(name) for name, _ in PINNED_COLUMNS} == dict(PINNED_COLUMNS)
    assert set(PINNED_TIMING) <= set(_records.TIMING_COLUMNS)


def test_a_part_written_before_a_column_was_added_reads_and_resumes(tmp_path) -> None:
    from tests.harness.cli_helpers import invoke

    grid = ["run", "--rigs", "tiny", "--solvers", "greedy", "--transfers", "delta", "--j-values", "1"]
    assert invoke(*grid, "--out", tmp_path, "--quiet").exit_code == 0
    (part,) = _records.part_files(tmp_path)
    whole = pq.read_table(part)
    older = whole.drop_columns(["rms_uncovered"]).replace_schema_metadata(whole.schema.metadata)
    pq.write_table(older, part)
    assert _records.part_problem(part) == ""
    frame = _records.read_records(tmp_path)
    assert list(frame.columns) == list(_records.RECORD_COLUMNS) and frame["rms_uncovered"].isna().all()
    result = invoke(*grid, "--resume", tmp_path)
    assert result.exit_code == 0 and "1 recorded before" in result.output, result.output
    assert (
        _records.part_files(tmp_path) == [part] and pq.read_table(part).num_columns == whole.num_columns - 1
    )


@pytest.mark.parametrize(
    ("change", "said"),
    [
        (lambda t: t.append_column("surprise", pa.array([1] * t.num_rows)), "'surprise' is not one"),
        (
            lambda t: t.set_column(t.column_names.index("rms"), "rms", t.column("rms").cast(pa.string())),
            "is string",
        ),
        (lambda t: t.drop_columns(["kind"]), "lacks the column(s) kind"),
    ],
)
def test_a_part_with_foreign_columns_is_not_records(tmp_path, change, said) -> None:
    part = sorted(BASELINE.glob("records/*.parquet"))[0]
    whole = pq.read_table(part)
    copy = tmp_path / part.name
    pq.write_table(change(whole).replace_schema_metadata(whole.schema.metadata), copy)
    assert said in _records.part_problem(copy)


def test_the_committed_baseline_reads_back_in_the_schema() -> None:
    parts = _records.part_files(BASELINE)
    assert parts, f"no part files in {BASELINE}"
    assert {path.name: _records.part_problem(path) for path in parts} == {path.name: "" for path in parts}
    frame = _records.read_records(BASELINE)
    assert list(frame.columns) == list(_records.RECORD_COLUMNS)
    assert set(frame["kind"]) == {"cell", "expression", "transfer"}


def test_the_expression_columns_follow_the_dataclass() -> None:
    """Each field and property of `packing.Expression` but the unrecorded ones is a column of its name
    (``index`` is ``expression``) typed by its annotation; the others are computed by the cell."""
    hints = typing.get_type_hints(Expression)
    annotations = {field.name: hints[field.name] for field in dataclasses.fields(Expression)}
    for name, member in vars(Expression).items():
        if isinstance(member, property):
            annotations[name] = typing.get_type_hints(member.fget)["return"]
    expected = {
        "expression" if name == "index" else name: annotation
        for name, annotation in annotations.items()
        if name not in _rows.UNRECORDED_ATTRIBUTES
    }
    assert _rows.UNRECORDED_ATTRIBUTES == {"items", "solution", "backend", "version"}
    assert set(_rows.expression_columns()) == set(expected)
    types = {
        str: pa.string(),
        int: pa.int64(),
        float: pa.float64(),
        float | None: pa.float64(),
        tuple[str, ...]: _STRINGS,
        Termination: pa.string(),
        packing.SolutionStatus: pa.string(),
    }
    for column, annotation in expected.items():
        assert _records.RECORD_COLUMNS[column] == types[annotation], column
    computed = set(_records.expression_section()) - set(expected)
    assert computed == {"n_chosen", "covered", "coverage"}


def test_a_field_added_to_the_expression_becomes_a_column() -> None:
    @dataclasses.dataclass(frozen=True)
    class CheckedExpression(Expression):
        check_time: float = 0.0
        rejected: tuple[str, ...] = ()

    section = _records.expression_section(CheckedExpression)
    assert list(section) == [*_records.expression_section(), "check_time", "rejected"]
    assert section["check_time"] == pa.float64() and section["rejected"] == _STRINGS
    assert _rows.expression_columns(CheckedExpression)["check_time"] == ("check_time", float)


def test_a_column_whose_attribute_is_gone_is_refused() -> None:
    @dataclasses.dataclass(frozen=True)
    class Bare:
        index: int
        shapes: tuple[str, ...]

    with pytest.raises(TypeError, match=r"records columns \['extra_examples', 'objective', .*Bare"):
        _records.expression_section(Bare)


def test_an_attribute_no_column_can_hold_is_refused() -> None:
    @dataclasses.dataclass(frozen=True)
    class WithVertices(Expression):
        vertices: np.ndarray | None = None

    with pytest.raises(TypeError, match="cannot hold values annotated"):
        _rows.expression_columns(WithVertices)


@pytest.mark.parametrize(
    ("annotation", "expected"),
    [
        (bool, bool),
        (int | None, int),
        (float | None, float),
        (typing.Optional[str], str),  # noqa: UP045 - the older spelling of the same annotation
        (tuple[str, ...], list[str]),
        (tuple[float, ...], list[float]),
        (Termination, str),
        (packing.SolutionStatus, str),
    ],
)
def test_column_types_of_annotations(annotation: object, expected: object) -> None:
    assert _rows.column_type(annotation) == expected


@pytest.mark.parametrize("annotation", [tuple[str, int], tuple[tuple[str, ...], ...], dict[str, int], object])
def test_annotations_without_a_column_type(annotation: object) -> None:
    with pytest.raises(TypeError, match="cannot hold values annotated"):
        _rows.column_type(annotation)


def test_an_expression_record_holds_plain_values() -> None:
    record = _rows.expression_record(_expression(extra_examples=("browUp",), extra_time=0.0625))
    assert record == {
        "expression": 1,
        "shapes": ["jawOpen", "smile_L", "smile_R"],
        "objective": 2.5,
        "presolve_time": 0.125,
        "n_items": 4,
        "vertex_rows": 30,
        "clique_rows": 3,
        "extra_examples": ["browUp"],
        "extra_time": 0.0625,
        "bound": None,
        "termination": "completed",
        "status": "feasible",
        "build_time": 0.25,
        "solve_time": 0.5,
        "cpu_time": 0.75,
        "message": "",
        "fallback": "",
    }
    assert type(record["termination"]) is str and type(record["status"]) is str


def test_expression_rows_add_what_the_cell_computes() -> None:
    first = _expression()
    second = _expression(index=2, shapes=("browUp",), items=("browUp",), objective=1.0)
    rows = _cell._expression_rows({"cell": "c" * 16}, [first, second], n_shapes=8)
    assert [row["n_chosen"] for row in rows] == [3, 1]
    assert [row["covered"] for row in rows] == [3, 4] and rows[-1]["coverage"] == 0.5
    assert [row["objective"] for row in rows] == [2.5, 1.0] and "weight" not in rows[0]
    table = _records.records_table(rows)
    assert table.schema.equals(_records.RECORD_SCHEMA)
    assert table.column("termination").to_pylist() == ["completed", "completed"]
