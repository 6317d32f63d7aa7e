"""Transfer plugins found through the ``harness.transfers`` entry-point group (`registry.PluginRegistry`):
listed without importing them, loaded on first use, a load failure or a non-`Transfer` class reported as
unavailable with the reason, a name registered twice warned about."""

from __future__ import annotations

import dataclasses
import typing
from collections.abc import Iterable
from typing import Any

from registry import SETTING_TYPES, Availability, PluginInfo, PluginRegistry, Setting
from transfer._base import Transfer

GROUP = "harness.transfers"


def _check(plugin: Any, name: str) -> str | None:
    """What a loaded transfer plugin lacks, or None."""
    if not (isinstance(plugin, type) and issubclass(plugin, Transfer)):
        return "is not a transfer.Transfer subclass"
    if plugin.name != name:
        return f"declares name {plugin.name!r}, registered as {name!r}"
    return None


TRANSFERS = PluginRegistry(GROUP, "transfer method", _check)


def add_file(path: str) -> str:
    """Register the transfer method class one Python file defines, under its ``name``, for this process
    and the processes it starts (`registry.PluginRegistry.add_file`); returns that name."""
    return TRANSFERS.add_file(path)


def names() -> list[str]:
    """Names of the installed transfer methods, sorted (no plugin module is imported)."""
    return TRANSFERS.names()


def availability(name: str) -> Availability:
    """Whether transfer method ``name`` loads and can run here, and why not."""
    return TRANSFERS.availability(name)


def info(selected: Iterable[str] | None = None) -> list[PluginInfo]:
    """Availability, version and class of every (or each selected) transfer method."""
    return TRANSFERS.info(selected)


def get(name: str, **params: object) -> Transfer:
    """A transfer method by name, configured with ``params``.

    Parameters
    ----------
    name : str
        Entry-point name in the ``harness.transfers`` group (see `names`).
    **params
        The method's parameters (fields of its class); others keep their documented defaults.

    Returns
    -------
    Transfer
        Callable ``(template, target_neutral, weights, examples) -> (K, N, 3) deltas``.

    Raises
    ------
    ValueError
        Unknown name (the message lists the valid ones), unknown parameter (the message lists the
        accepted ones) or a bad parameter value.
    registry.PluginUnavailableError
        The method's module fails to load or does not define a `Transfer`.
    """
    cls = TRANSFERS.load(name)
    accepted = {field.name for field in dataclasses.fields(cls)} if dataclasses.is_dataclass(cls) else set()
    unknown = sorted(set(params) - accepted)
    if unknown:
        raise ValueError(
            f"transfer method {name!r} has no parameter {', '.join(unknown)}; "
            f"accepted: {', '.join(sorted(accepted)) or 'none'}"
        )
    return cls(**_typed(name, cls, params))


def _typed(name: str, cls: type, params: dict[str, object]) -> dict[str, object]:
    """``params`` checked against the types of the fields they set, where a field is a plain ``bool``,
    ``int``, ``float`` or ``str`` (`registry.Setting`: ``align=3`` is no flag); the class's own checks
    judge the rest (ranges, unions).

    Raises
    ------
    ValueError
        Naming the method, the parameter and what it must be.
    """
    if not params:
        return params
    hints = typing.get_type_hints(cls)
    checked = dict(params)
    for field in dataclasses.fields(cls):
        kind = hints.get(field.name)
        if field.name in params and kind in SETTING_TYPES:
            try:
                checked[field.name] = Setting(field.name, kind, field.default, "").checked(params[field.name])
            except ValueError as error:
                raise ValueError(f"transfer method {name!r}: {error}") from None
    return checked
