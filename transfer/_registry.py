"""Transfer plugins found through the ``harness.transfers`` entry-point group, loaded on first use."""

from __future__ import annotations

import dataclasses
from functools import cache
from typing import TYPE_CHECKING

from transfer._base import Transfer

if TYPE_CHECKING:
    from importlib.metadata import EntryPoint

GROUP = "harness.transfers"


@cache
def _entry_points() -> dict[str, EntryPoint]:
    from importlib.metadata import entry_points

    return {point.name: point for point in entry_points(group=GROUP)}


def names() -> list[str]:
    """Names of the installed transfer methods, sorted (no plugin module is imported)."""
    return sorted(_entry_points())


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
        Unknown name (the message lists the installed ones), unknown parameter (the message lists the
        accepted ones) or a bad parameter value.
    """
    points = _entry_points()
    if name not in points:
        installed = ", ".join(sorted(points)) or "none"
        raise ValueError(f"unknown transfer method {name!r}; installed: {installed}")
    cls = points[name].load()
    accepted = {field.name for field in dataclasses.fields(cls)} if dataclasses.is_dataclass(cls) else set()
    unknown = sorted(set(params) - accepted)
    if unknown:
        raise ValueError(
            f"transfer method {name!r} has no parameter {', '.join(unknown)}; "
            f"accepted: {', '.join(sorted(accepted)) or 'none'}"
        )
    return cls(**params)
