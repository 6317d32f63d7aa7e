"""A plugin's settings, declared with their types and ranges (``cpsat[workers=2]``, ``highs[presolve=off]``).

A plugin class declares what it takes as a class attribute ``settings``, a tuple of `Setting`::

    settings: ClassVar[tuple[Setting, ...]] = (
        Setting("workers", int, 1, "CP-SAT search workers", low=1, high=64),
    )

`checked_settings` judges the values a user gave against it before anything runs (the harness before any
cell, so a bad value is one line naming the option, never a failed cell), and ``harness list`` shows it. A
plugin that declares no ``settings`` takes the values as keyword arguments of its constructor, which judges
them itself.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from registry._errors import HarnessError

#: The types a setting may have.
SETTING_TYPES = (bool, int, float, str)
_TYPE_WORDS = {bool: "on or off", int: "an integer", float: "a number", str: "a word"}


@dataclass(frozen=True)
class Setting:
    """One keyword argument a plugin takes.

    Attributes
    ----------
    name : str
    type : type
        ``bool``, ``int``, ``float`` or ``str`` (`SETTING_TYPES`).
    default : object
        The value when the setting is not given (None: the backend's own choice).
    help : str
        What it does, in one line.
    low, high : float, optional
        The smallest and largest value of a number (inclusive; ``high_open`` makes ``high`` exclusive).
    choices : tuple of str
        The words a ``str`` setting may be (empty: any word).
    high_open : bool
        Whether ``high`` itself is out of range.
    """

    name: str
    type: type
    default: object
    help: str
    low: float | None = None
    high: float | None = None
    choices: tuple[str, ...] = ()
    high_open: bool = False

    def __post_init__(self) -> None:
        if self.type not in SETTING_TYPES:
            raise TypeError(f"setting {self.name!r}: type must be one of bool, int, float, str")

    def domain(self) -> str:
        """What a value must be, in words: ``an integer in 1..64``, ``one of auto, cbcbox``."""
        if self.choices:
            return f"one of {', '.join(self.choices)}"
        words = _TYPE_WORDS[self.type]
        if self.low is None and self.high is None:
            return words
        low = "" if self.low is None else f"{self.low:g}"
        high = "" if self.high is None else f"{self.high:g}"
        return f"{words} in [{low}, {high}{')' if self.high_open else ']'}"

    def checked(self, value: object) -> object:
        """``value`` as this setting takes it (an integer for a ``float`` setting becomes a float).

        Raises
        ------
        ValueError
            When it is not of the type, out of the range or not one of the choices.
        """
        if self.type is bool:
            if not isinstance(value, bool):
                raise ValueError(self._refused(value))
            return value
        if self.type is str:
            text = ("on" if value else "off") if isinstance(value, bool) else str(value)
            if self.choices and text not in self.choices:
                raise ValueError(self._refused(value))
            return text
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ValueError(self._refused(value))
        if self.type is int and not isinstance(value, int):
            raise ValueError(self._refused(value))
        number = self.type(value)
        if isinstance(number, float) and not math.isfinite(number):
            raise ValueError(self._refused(value))
        too_high = self.high is not None and (number >= self.high if self.high_open else number > self.high)
        if (self.low is not None and number < self.low) or too_high:
            raise ValueError(self._refused(value))
        return number

    def describe(self) -> str:
        """``workers (an integer in [1, 64], default 1): CP-SAT search workers``."""
        default = "the backend's own" if self.default is None else _spelled(self.default)
        return f"{self.name} ({self.domain()}, default {default}): {self.help}"

    def _refused(self, value: object) -> str:
        return f"{self.name} must be {self.domain()}, got {_spelled(value)}"


def _spelled(value: object) -> str:
    if isinstance(value, bool):
        return "on" if value else "off"
    return str(value)


def declared_settings(plugin: object) -> tuple[Setting, ...] | None:
    """The settings a plugin class (or instance) declares, or None when it declares none."""
    declared = getattr(plugin, "settings", None)
    if declared is None:
        return None
    if not isinstance(declared, tuple) or not all(isinstance(item, Setting) for item in declared):
        raise HarnessError(f"{_plugin_name(plugin)}: its 'settings' is not a tuple of registry.Setting")
    return declared


def checked_settings(plugin: object, given: Mapping[str, object]) -> dict[str, object]:
    """The values ``given`` for a plugin that declares its settings, each checked (`Setting.checked`).

    Returns
    -------
    dict
        The values as the plugin takes them; ``given`` itself for a plugin that declares none.

    Raises
    ------
    HarnessError
        One line naming the setting: unknown (listing the known ones), of the wrong type or out of range.
    """
    declared = declared_settings(plugin)
    if declared is None:
        return dict(given)
    known = {setting.name: setting for setting in declared}
    checked = {}
    for name, value in given.items():
        if name not in known:
            valid = ", ".join(known) or "none"
            raise HarnessError(f"{_plugin_name(plugin)} has no setting {name!r} (its settings: {valid})")
        try:
            checked[name] = known[name].checked(value)
        except ValueError as error:
            raise HarnessError(str(error)) from None
    return checked


def _plugin_name(plugin: object) -> str:
    return str(getattr(plugin, "name", None) or getattr(plugin, "__name__", type(plugin).__name__))
