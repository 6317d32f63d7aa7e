"""Command-line options for artist constraints and regions, shared by ``harness pack`` and ``harness run``.

``--together A,B`` and ``--apart A,B`` (repeatable) and ``--constraints FILE.json`` give the artist
constraints (`packing.parse_pair`, `packing.read_constraints`): a together pair is one item, an apart pair
never shares an expression. ``--regions FILE`` replaces the rig's vertex regions for motion symmetry
(sec. 4.4.2, eqs. 11-12) with a JSON object of region name -> vertex indices, or the face groups of an OBJ of
the rig's mesh (`rigs.read_regions`). Shape and region names are
checked against the rig by `packing` (an unknown name is a one-line error with the close matches).
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import TypedDict

import click

from harness._cli_types import Command


class ShapePair(click.ParamType):
    """``A,B`` -> ``("A", "B")`` (`packing.parse_pair`)."""

    name = "A,B"

    def convert(
        self, value: object, param: click.Parameter | None, ctx: click.Context | None
    ) -> tuple[str, str]:
        if isinstance(value, tuple):
            return value
        import packing

        try:
            return packing.parse_pair(str(value))
        except ValueError as error:
            self.fail(str(error), param, ctx)


SHAPE_PAIR = ShapePair()
INPUT_FILE = click.Path(exists=True, dir_okay=False, path_type=Path)


def constraint_options(command: Command) -> Command:
    """Add ``--together``, ``--apart``, ``--constraints`` and ``--regions`` to a click command; its callback
    receives ``together``, ``apart``, ``constraints`` and ``regions`` (see `constraint_params`)."""
    options = [
        click.option(
            "--together",
            type=SHAPE_PAIR,
            multiple=True,
            help="Two shapes always in the same expression (one item), e.g. eyeLookOut_L,eyeLookIn_R. "
            "Repeatable.",
        ),
        click.option(
            "--apart",
            type=SHAPE_PAIR,
            multiple=True,
            help="Two shapes never in the same expression, e.g. eyeLookOut_L,eyeLookOut_R. Repeatable.",
        ),
        click.option(
            "--constraints",
            type=INPUT_FILE,
            help='JSON file of artist constraints: {"together": [["A", "B"], ...], "apart": [...]}.',
        ),
        click.option(
            "--regions",
            type=INPUT_FILE,
            help="Vertex regions for motion symmetry (eqs. 11-12), replacing the rig's own: a JSON file of "
            "region name -> vertex indices, or an OBJ of the rig's mesh whose face groups are the regions.",
        ),
    ]
    for option in reversed(options):
        command = option(command)
    return command


class ConstraintParams(TypedDict):
    """The packing parameters (`packing.PackingParams` fields) the constraint options give."""

    together: tuple[tuple[str, str], ...]
    apart: tuple[tuple[str, str], ...]
    regions: str | None


def constraint_params(
    together: Iterable[tuple[str, str]],
    apart: Iterable[tuple[str, str]],
    constraints: Path | None,
    regions: Path | None,
) -> ConstraintParams:
    """The packing parameters ``together``, ``apart`` and ``regions`` from the options of
    `constraint_options`: the file's pairs first, then the options', each pair once.

    Raises
    ------
    ValueError
        For an unreadable or malformed constraints file (naming it).
    """
    import packing

    given = packing.read_constraints(constraints) if constraints is not None else {}
    return {
        "together": tuple(dict.fromkeys([*given.get("together", ()), *together])),
        "apart": tuple(dict.fromkeys([*given.get("apart", ()), *apart])),
        "regions": None if regions is None else str(regions),
    }
