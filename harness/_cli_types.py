"""What the `harness` commands share: value types (comma lists, durations, on/off/both) and the console."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Generic, TypeVar

import click

from harness._bounds import AXIS_MAX, COUNT_MAX, JOBS_MAX, RIG_SEED_MAX, SEED_MAX, SEEDS_MAX
from harness._durations import parse_duration
from harness._settings import expand, split_requests
from registry import HarnessError

if TYPE_CHECKING:
    from rich.console import Console

NONE_WORDS = ("none", "off", "no")

#: A command's callback, as click's option decorators take and return it.
Command = TypeVar("Command", bound=Callable[..., object])
#: The type of the items of a `CommaList`.
Item = TypeVar("Item")


class CommaList(click.ParamType, Generic[Item]):
    """``a,b,c`` -> tuple of items converted by ``item`` (``none`` -> None when ``allow_none``).

    ``item`` is a function of one text, or the click type of the option's single value, whose own check
    (a range, say) then holds for every item and words the error as it does for a single value.
    """

    def __init__(
        self, item: Callable[[str], Item] | click.ParamType, name: str, *, allow_none: bool = False
    ) -> None:
        self.item = item
        self.name = name
        self.allow_none = allow_none

    def convert(
        self, value: object, param: click.Parameter | None, ctx: click.Context | None
    ) -> tuple[Item | None, ...]:
        if isinstance(value, tuple):
            return value
        parts = [part.strip() for part in str(value).split(",") if part.strip()]
        if not parts:
            self.fail(f"expected a comma-separated list of {self.name}, got {value!r}", param, ctx)
        converted: list[Item | None] = []
        for part in parts:
            if self.allow_none and part.lower() in NONE_WORDS:
                converted.append(None)
                continue
            if isinstance(self.item, click.ParamType):
                converted.append(self.item.convert(part, param, ctx))
                continue
            try:
                converted.append(self.item(part))
            except ValueError:
                self.fail(f"{part!r} is not a valid {self.name} (in {value!r})", param, ctx)
        return tuple(converted)


class PluginList(click.ParamType):
    """``cpsat[workers=1,2],highs`` -> the labels it stands for (`harness._settings`), in order."""

    name = "plugins"

    def convert(
        self, value: object, param: click.Parameter | None, ctx: click.Context | None
    ) -> tuple[str, ...]:
        if isinstance(value, tuple):
            return value
        try:
            labels = [label for request in split_requests(str(value)) for label in expand(request)]
        except ValueError as error:
            self.fail(str(error), param, ctx)
        if not labels:
            self.fail(f"expected a comma-separated list of plugin names, got {value!r}", param, ctx)
        return tuple(dict.fromkeys(labels))


def seed_number(text: str) -> int:
    """A seed: ASCII digits, >= 0 (ValueError otherwise, an empty text too)."""
    if not text.isascii() or not text.isdigit():
        raise HarnessError(text)
    return int(text)


class FiniteFloatRange(click.FloatRange):
    """A `click.FloatRange` that also refuses ``nan`` and ``inf`` (which a range check lets through)."""

    def convert(self, value: object, param: click.Parameter | None, ctx: click.Context | None) -> float:
        number = float(super().convert(value, param, ctx))
        if not math.isfinite(number):
            self.fail(f"expected a finite number, got {value!r}", param, ctx)
        return number


#: A solver seed option's type.
SOLVER_SEED = click.IntRange(0, SEED_MAX)
#: The seed of the scan-like examples (repetition r adds r; the records keep it as a 64-bit integer).
SCAN_SEED = click.IntRange(0, SEED_MAX)
#: A generated rig's seed.
RIG_SEED = click.IntRange(0, RIG_SEED_MAX)
#: Repetitions or permutations of every cell.
AXIS_COUNT = click.IntRange(1, AXIS_MAX)
#: Worker processes.
JOBS = click.IntRange(1, JOBS_MAX)
#: Most expressions of a sequence, or most shapes of one.
COUNT = click.IntRange(1, COUNT_MAX)


class SeedList(click.ParamType):
    """``0-4`` or ``0,3,7`` (ranges inclusive, mixed as ``0-2,9``) -> the seeds, in order, without repeats."""

    name = "seeds"

    def convert(
        self, value: object, param: click.Parameter | None, ctx: click.Context | None
    ) -> tuple[int, ...]:
        if isinstance(value, tuple):
            return value
        seeds: list[int] = []
        for part in (part.strip() for part in str(value).split(",")):
            first, dash, last = part.partition("-")
            try:
                low = seed_number(first)
                high = seed_number(last) if dash else low
            except ValueError:
                self.fail(f"{part!r} is not a seed or a range of seeds like 0-4 (in {value!r})", param, ctx)
            if high < low:
                self.fail(f"{part!r}: a range goes up (in {value!r})", param, ctx)
            if high > RIG_SEED_MAX:
                self.fail(f"{part!r}: seeds go up to 2**63 - 1 = {RIG_SEED_MAX} (in {value!r})", param, ctx)
            if high - low + len(seeds) >= SEEDS_MAX:
                self.fail(f"{value!r} makes more than {SEEDS_MAX} seeds", param, ctx)
            seeds += range(low, high + 1)
        return tuple(dict.fromkeys(seeds))


class Duration(click.ParamType):
    """``30s``, ``2m``, ``500ms``, ``1h`` or plain seconds -> float seconds; ``none`` -> None."""

    name = "duration"

    def convert(
        self, value: object, param: click.Parameter | None, ctx: click.Context | None
    ) -> float | None:
        if value is None or isinstance(value, float):
            return value
        if str(value).strip().lower() in NONE_WORDS:
            return None
        try:
            seconds = parse_duration(str(value))
        except ValueError as error:
            self.fail(str(error), param, ctx)
        if seconds <= 0:
            self.fail(f"must be positive, got {value!r}", param, ctx)
        return seconds


class Switch(click.ParamType):
    """``on`` / ``off`` / ``both`` -> a tuple of booleans to sweep."""

    name = "on|off|both"
    _VALUES = {"on": (True,), "off": (False,), "both": (True, False)}

    def convert(
        self, value: object, param: click.Parameter | None, ctx: click.Context | None
    ) -> tuple[bool, ...]:
        if isinstance(value, tuple):
            return value
        try:
            return self._VALUES[str(value).strip().lower()]
        except KeyError:
            self.fail(f"expected on, off or both, got {value!r}", param, ctx)


def positive_int(text: str) -> int:
    """An int in 1..`COUNT_MAX` (ValueError otherwise)."""
    number = int(text)
    if not 1 <= number <= COUNT_MAX:
        raise HarnessError(text)
    return number


NAMES = CommaList(str, "names")
PLUGINS = PluginList()
SEEDS = SeedList()
POSITIVE_INTS = CommaList(positive_int, f"positive integers up to {COUNT_MAX}")
DURATION = Duration()
SWITCH = Switch()


#: Width of what commands print to a pipe or a file when ``COLUMNS`` does not say: wide enough that no
#: table is cut (a table is as wide as its content), the text plain.
PIPED_WIDTH = 1000


def terminal(*, stderr: bool = False) -> Console:
    """The console commands print to (made per use, so its width follows ``COLUMNS``); stderr for errors.
    Printed to a pipe or a file, without ``COLUMNS``, it is `PIPED_WIDTH` wide: plain text, nothing cut.

    rich is imported here, not with the module, so that commands that print nothing start faster."""
    import os
    import sys

    from rich.console import Console

    stream = sys.stderr if stderr else sys.stdout
    piped = not (hasattr(stream, "isatty") and stream.isatty()) and "COLUMNS" not in os.environ
    return Console(highlight=False, stderr=stderr, soft_wrap=stderr, width=PIPED_WIDTH if piped else None)
