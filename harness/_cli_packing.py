"""Command-line options of the packing parameters, declared once for ``harness pack``, ``harness instances
export`` and ``harness run``.

`PACKING_OPTIONS` names each option, the `packing.PackingParams` field it sets (``--cap`` is
``max_per_expression``, the cap of sec. 6), the click type of one value and its help; every default is the
`packing.PackingParams` default. `packing_options` adds them to a command, in one of two shapes:

- one value each (``pack``, ``instances export``): ``--mu 0.3``, ``--symmetry/--no-symmetry``; the
  callback turns them into the keyword arguments of `packing.analyse` with `packing_params`;
- a grid axis each (``run``, ``grid=True``): a comma list of values, each checked as the single value is
  (``--mu 0.2,0.3``), and the switches ``--symmetry on|off|both`` with ``--no-symmetry`` for ``off``; the
  callback takes the axes given out of its arguments with `grid_axes`. A preset may set an axis: its help
  says which.

The artist constraints and regions beside them are `harness._cli_constraints.constraint_options`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, MutableMapping
from dataclasses import dataclass
from typing import Any

import click
from click.core import ParameterSource

from harness._cli_types import COUNT, SWITCH, CommaList, Command, FiniteFloatRange
from packing import PackingParams

#: Most expressions of the one sequence of ``harness pack`` and ``harness instances export`` (a run's
#: presets say their own).
JMAX = 20


@dataclass(frozen=True)
class PackingOption:
    """One packing option of the command line.

    Attributes
    ----------
    name : str
        The option (``--NAME``), the callback's argument and the `harness.RunConfig` axis.
    field : str
        The `packing.PackingParams` field it sets, whose default it has.
    kind : click.ParamType or None
        The type of one value; None for an on/off switch.
    help : str
        What it sets, with the paper's equation or section.
    unset : str
        What the option's absence means, for one whose default is None (``no cap``).
    """

    name: str
    field: str
    kind: click.ParamType | None
    help: str
    unset: str = ""

    @property
    def default(self) -> Any:
        """The `packing.PackingParams` default."""
        return next(field.default for field in dataclasses.fields(PackingParams) if field.name == self.field)


PACKING_OPTIONS: tuple[PackingOption, ...] = (
    PackingOption("mu", "mu", FiniteFloatRange(0, 1, min_open=True), "Binary blendshape threshold, eq. 2."),
    PackingOption("alpha", "alpha", FiniteFloatRange(0, 1), "Importance mix, eq. 4."),
    PackingOption("beta", "beta", FiniteFloatRange(min=0), "Uniqueness weight, eq. 4."),
    PackingOption("symmetry", "symmetry", None, "Force symmetry pairs together (sec. 4.4)."),
    PackingOption("importance", "importance", None, "Importance weights (eq. 4); off = every weight 1."),
    PackingOption("cap", "max_per_expression", COUNT, "Most shapes per expression (sec. 6).", "no cap"),
)


def packing_options(*, grid: bool) -> Callable[[Command], Command]:
    """Add the `PACKING_OPTIONS` to a click command: one value each, or with ``grid`` a grid axis each
    (module notes)."""
    options = [_grid_option(option) if grid else _single_option(option) for option in PACKING_OPTIONS]

    def add(command: Command) -> Command:
        for option in reversed(options):
            command = option(command)
        return command

    return add


def packing_params(values: Mapping[str, Any]) -> dict[str, Any]:
    """The `packing.PackingParams` keyword arguments of the single-value options among a callback's
    ``values``."""
    return {option.field: values[option.name] for option in PACKING_OPTIONS}


def grid_axes(ctx: click.Context, values: MutableMapping[str, Any]) -> dict[str, tuple[Any, ...]]:
    """The packing axes given on the command line (not their defaults), taken out of a callback's
    ``values``: a ``--no-NAME`` switch is the axis ``(False,)``."""
    given = {}
    for option in PACKING_OPTIONS:
        value = values.pop(option.name)
        if option.kind is None and values.pop(f"no_{option.name}"):
            value = (False,)
        elif value is None or ctx.get_parameter_source(option.name) is ParameterSource.DEFAULT:
            continue
        given[option.name] = value
    return given


def _single_option(option: PackingOption) -> Callable[[Command], Command]:
    if option.kind is None:
        flags = f"--{option.name}/--no-{option.name}"
        return click.option(flags, default=option.default, show_default=True, help=option.help)
    if option.default is None:
        return click.option(
            f"--{option.name}", type=option.kind, help=f"{option.help} [default: {option.unset}]"
        )
    return click.option(
        f"--{option.name}", type=option.kind, default=option.default, show_default=True, help=option.help
    )


def _grid_option(option: PackingOption) -> Callable[[Command], Command]:
    shown = f"[default: {_grid_default(option)}]"
    if option.kind is None:
        switch = click.option(
            f"--{option.name}",
            type=SWITCH,
            is_flag=False,
            flag_value="on",
            help=f"{option.help} On, off or both (a grid axis). {shown}",
        )
        negation = click.option(
            f"--no-{option.name}", f"no_{option.name}", is_flag=True, help=f"Same as --{option.name} off."
        )
        return lambda command: switch(negation(command))
    nothing = option.default is None
    kind = CommaList(option.kind, "numbers", allow_none=nothing)
    listed = "a comma list is a grid axis" + (f"; none = {option.unset}" if nothing else "")
    return click.option(f"--{option.name}", type=kind, help=f"{option.help[:-1]}; {listed}. {shown}")


def _grid_default(option: PackingOption) -> str:
    """The axis's default, then the presets that set it otherwise: ``on; sanity: off; full: both``."""
    from harness._grid import PRESETS  # (the grid's; ``harness --help`` lists the commands without it)

    said = [_show((option.default,))]
    said += [
        f"{name}: {_show(preset[option.name])}" for name, preset in PRESETS.items() if option.name in preset
    ]
    return "; ".join(said)


def _show(values: tuple[Any, ...]) -> str:
    if set(values) <= {True, False} and all(isinstance(value, bool) for value in values):
        return "both" if len(values) == 2 else ("on" if values[0] else "off")
    return ",".join("none" if value is None else f"{value:g}" for value in values)
