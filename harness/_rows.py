"""Rows of the records table as plain Python values, and the ``expression`` columns of `packing.Expression`.

A row is a mapping of column name to a plain number, string, flag, list or null (`Row`); `harness._cell`
makes a cell's rows, `harness._records` types their columns with Arrow, and both read the ``expression``
columns from one place (`expression_columns`): every recorded attribute of `packing.Expression`, typed by its
annotation (`column_type`), so that a field added to the expression is recorded with no list to update.
The ``cell`` row's facts of a packed sequence (`sequence_facts`) are made here too, for the cells that pack
their own sequence and those that replay a reference (`harness._replay`).
"""

from __future__ import annotations

import dataclasses
import enum
import functools
import types
import typing
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import packing
from packing import Expression

if TYPE_CHECKING:
    from packing import Pipeline

#: A value of one records column (`harness._records`): a plain number, string, flag, list or null.
RecordValue = str | int | float | bool | list[str] | list[float] | None
#: One row of the records table, by column name.
Row = dict[str, RecordValue]
#: The plain Python type of a records column: ``bool``, ``int``, ``float``, ``str`` or a list of one.
ColumnType = type | types.GenericAlias

#: Attributes of `packing.Expression` its ``expression`` row does not record: the item labels name its
#: shapes again, the solution is recorded through the attributes the expression reads from it, and the
#: solver's backend and version are the cell row's ``backend_version``.
UNRECORDED_ATTRIBUTES = frozenset({"items", "solution", "backend", "version"})
#: Records columns named otherwise than the `packing.Expression` attribute they record.
_COLUMN_NAMES = {"index": "expression"}
_SCALAR_TYPES = (bool, int, float, str)


def column_type(annotation: object) -> ColumnType:
    """The plain Python type of the records column recording values annotated ``annotation``.

    ``X | None`` is recorded as X (every column is nullable), ``tuple[X, ...]`` as ``list[X]`` and a string
    enumeration (`packing.Termination`, `packing.SolutionStatus`) as ``str``; ``bool``, ``int``, ``float``
    and ``str`` as themselves.

    Raises
    ------
    TypeError
        For any other annotation: a records column holds no arrays, mappings or objects.
    """
    origin, arguments = typing.get_origin(annotation), typing.get_args(annotation)
    if origin in (types.UnionType, typing.Union) and len(arguments) == 2 and type(None) in arguments:
        return column_type(next(argument for argument in arguments if argument is not type(None)))
    if origin is tuple and len(arguments) == 2 and arguments[1] is Ellipsis and arguments[0] in _SCALAR_TYPES:
        return list[arguments[0]]
    if isinstance(annotation, type) and issubclass(annotation, enum.StrEnum):
        return str
    if annotation in _SCALAR_TYPES:
        return annotation
    raise TypeError(f"a records column cannot hold values annotated {annotation!r}")


@functools.cache
def expression_columns(
    expression_type: type[Expression] = Expression,
) -> Mapping[str, tuple[str, ColumnType]]:
    """The ``expression`` record columns an expression fills: column -> (attribute, plain type).

    Every field and public property of ``expression_type`` (`packing.Expression`, whose properties read
    its `packing.Solution`) but `UNRECORDED_ATTRIBUTES` is one column, named as the attribute (``index``
    is ``expression``) and typed by its annotation (`column_type`): a field added to the dataclass is
    recorded with no column list to update (`harness._records` places its column after the others).
    """
    hints = typing.get_type_hints(expression_type)
    annotations = {field.name: hints[field.name] for field in dataclasses.fields(expression_type)}
    for owner in reversed(expression_type.__mro__):
        for name, member in vars(owner).items():
            if isinstance(member, property) and not name.startswith("_"):
                annotations[name] = typing.get_type_hints(member.fget)["return"]
    return {
        _COLUMN_NAMES.get(name, name): (name, column_type(annotation))
        for name, annotation in annotations.items()
        if name not in UNRECORDED_ATTRIBUTES
    }


def expression_record(expression: Expression) -> Row:
    """The values of an expression's `expression_columns`, as plain Python values of the column types."""
    return {
        column: _plain(getattr(expression, attribute), kind)
        for column, (attribute, kind) in expression_columns().items()
    }


def _plain(value: object, kind: ColumnType) -> RecordValue:
    if value is None:
        return None
    if isinstance(kind, types.GenericAlias):
        (item,) = typing.get_args(kind)
        return [item(element) for element in value]
    return kind(value)


def sequence_facts(pipeline: Pipeline, expressions: Sequence[Expression]) -> Row:
    """The ``cell`` row's columns a sequence and its analysis give: the analysis's seconds, the lower bound
    on the number of expressions (`packing.expression_lower_bound`), the symmetry pairs and empty shapes
    counted (sec. 4.1, 4.4), and the backend and version of the first answer that names one."""
    return {
        "analysis_time": pipeline.analysis_time,
        "lower_bound": packing.expression_lower_bound(pipeline.analysis).lower,
        "n_pairs": len(pipeline.analysis.pairs),
        "n_empty": len(pipeline.analysis.empty_names),
        "backend_version": next((f"{e.backend} {e.version}".strip() for e in expressions if e.backend), ""),
    }
