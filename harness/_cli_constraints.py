"""Command-line options for artist constraints and regions, shared by ``harness pack`` and ``harness run``.

``--together A,B`` and ``--apart A,B`` (repeatable) and ``--constraints FILE.json`` give the artist
constraints (`packing.parse_pair`, `packing.read_constraints`): a together pair is one item, an apart pair
never shares an expression. ``--regions FILE`` replaces the rig's vertex regions for motion symmetry
(sec. 4.4.2, eqs. 11-12) with a JSON object of region name -> vertex indices, or the face groups of an OBJ of
the rig's mesh (`rigs.read_regions`). ``harness pack`` hands packing the regions file (`constraint_params`),
``harness run`` its content, read once for every cell (`grid_constraints`). Shape and region names are
checked against the rig by `packing` (an unknown name is a one-line error with the close matches).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypedDict

import click

from harness._cli_types import Command
from registry import HarnessError

if TYPE_CHECKING:
    from rigs import Rig

#: A file the options read (checked when read, so that a missing file is one line naming it).
INPUT_FILE = click.Path(dir_okay=False, path_type=Path)


def constraint_options(command: Command) -> Command:
    """Add ``--together``, ``--apart``, ``--constraints`` and ``--regions`` to a click command; its callback
    receives ``together``, ``apart``, ``constraints`` and ``regions`` (see `constraint_params`)."""
    options = [
        click.option(
            "--together",
            multiple=True,
            metavar="A,B",
            help="Two shapes always in the same expression (one item), e.g. mouthSmile_L,cheekSquint_L. "
            "Repeatable.",
        ),
        click.option(
            "--apart",
            multiple=True,
            metavar="A,B",
            help="Two shapes never in the same expression, e.g. jawOpen,mouthFunnel. Repeatable.",
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
    #: The constraints file each of its pairs came from, so that a name the rig lacks is told naming it
    #: (`check_file_pairs`; `session._constraints.session_constraints` takes it out before packing).
    constraint_origins: dict[tuple[str, str], str]


def check_file_pairs(
    rig: Rig, pairs: Mapping[str, Iterable[Iterable[str]]], origins: Mapping[tuple[str, str], str]
) -> None:
    """Refuse a ``together`` or ``apart`` pair read from a constraints file (``origins``: pair -> file,
    `constraint_params`) that names a shape ``rig`` lacks, naming the file; the options' pairs are checked
    by `packing`, naming the option.

    Raises
    ------
    HarnessError
        ``FILE: together A,B: <rig>: no blendshape named 'B'; close matches: ...``.
    """
    for kind in ("together", "apart"):
        for pair in pairs.get(kind, ()):
            pair = tuple(pair)
            origin = origins.get(pair)
            if origin is None:
                continue
            for name in pair:
                try:
                    rig.index(name)
                except ValueError as error:  # RigError names the rig, the shape and close matches
                    raise HarnessError(f"{origin}: {kind} {','.join(pair)}: {error}") from None


def constraint_params(
    together: Iterable[str],
    apart: Iterable[str],
    constraints: Path | None,
    regions: Path | None,
) -> ConstraintParams:
    """The packing parameters ``together``, ``apart`` and ``regions`` from the options of
    `constraint_options` (``A,B`` texts and file paths): the file's pairs first, then the options', each
    pair once; ``constraint_origins`` maps each pair of the file to its path.

    Raises
    ------
    ValueError
        For a malformed pair (naming the option) or an unreadable or malformed constraints file (naming it).
    """
    import packing

    given = packing.read_constraints(constraints) if constraints is not None else {}
    both = {frozenset(pair) for pair in given.get("together", ())} & {
        frozenset(pair) for pair in given.get("apart", ())
    }
    if both:
        raise HarnessError(
            f"{constraints}: {','.join(sorted(min(both, key=sorted)))} is both a together and an apart pair"
        )
    pairs = {}
    for kind, texts in (("together", together), ("apart", apart)):
        parsed = []
        for text in texts:
            try:
                parsed.append(packing.parse_pair(text))
            except ValueError as error:
                raise HarnessError(f"--{kind}: {error}") from None
        pairs[kind] = tuple(dict.fromkeys([*given.get(kind, ()), *parsed]))
    return {
        "together": pairs["together"],
        "apart": pairs["apart"],
        "regions": None if regions is None else str(regions),
        "constraint_origins": {pair: str(constraints) for kind in pairs for pair in given.get(kind, ())},
    }


def grid_constraints(
    together: Iterable[str],
    apart: Iterable[str],
    constraints: Path | None,
    regions: Path | None,
) -> tuple[dict[str, Any], dict[tuple[str, str], str]]:
    """The `harness.RunConfig` fields the constraint options give, only those given: ``together`` and
    ``apart`` as in `constraint_params`, and ``regions`` read from the file (JSON or OBJ face groups, as
    for ``harness pack``) as `harness._grid.regions_tuple` (the content, so a resumed or distributed run
    does not need the file; each cell checks the indices against its rig), with the constraints file of
    each pair read from one (``constraint_origins`` of `constraint_params`, for `check_file_pairs`).

    Raises
    ------
    ValueError
        For an unreadable or malformed constraints or regions file (naming it).
    """
    import rigs
    from harness._grid import regions_tuple

    together, apart = tuple(together), tuple(apart)
    given: dict[str, Any] = {}
    origins: dict[tuple[str, str], str] = {}
    if together or apart or constraints is not None:
        pairs = constraint_params(together, apart, constraints, None)
        given.update(together=pairs["together"], apart=pairs["apart"])
        origins = pairs["constraint_origins"]
    if regions is not None:
        read = rigs.read_regions(regions, None)
        if not read:
            raise HarnessError(f"{regions}: holds no regions")
        given["regions"] = regions_tuple({name: indices.tolist() for name, indices in read.items()})
    return given, origins
