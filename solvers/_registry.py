"""Solver discovery through the ``harness.solvers`` entry-point group (`registry.PluginRegistry`).

Listing names reads installed metadata only; loading a plugin imports its module, not its backend. A
plugin that fails to import, lacks what a `Solver` has, declares capabilities of another type or another
name than it is registered under is listed as unavailable with the reason.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from registry import (
    Availability,
    HarnessError,
    PluginInfo,
    PluginRegistry,
    PluginUnavailableError,
    UnknownPluginError,
    checked_settings,
    declared_settings,
    missing_attributes,
)
from solvers._base import Capabilities
from solvers._loaded import LoadedSolver, load

#: Entry-point group that solver plugins register under.
GROUP = "harness.solvers"


class UnknownSolverError(UnknownPluginError):
    """No solver plugin of that name is installed."""


class SolverUnavailableError(PluginUnavailableError):
    """The solver plugin is installed but cannot run here; ``availability`` says why."""


def _check(plugin: Any, name: str) -> str | None:
    """What a loaded solver plugin lacks, or None."""
    missing = missing_attributes(plugin, ("name", "capabilities", "availability", "solve"))
    if missing:
        return f"is not a Solver: it {missing}"
    if not isinstance(plugin.capabilities, Capabilities):
        return "has capabilities that are not a solvers.Capabilities"
    if plugin.name != name:
        return f"declares name {plugin.name!r}, registered as {name!r}"
    if plugin.capabilities.minimum_cover and not hasattr(plugin, "solve_colouring"):
        return "declares minimum_cover but has no solve_colouring"
    try:
        declared_settings(plugin)
    except HarnessError as error:
        return str(error)
    return None


SOLVERS = PluginRegistry(
    GROUP, "solver", _check, unknown=UnknownSolverError, unavailable=SolverUnavailableError
)


def refresh() -> None:
    """Forget discovered plugins and loaded classes (after installing or removing a plugin)."""
    SOLVERS.refresh()


def add_file(path: str) -> str:
    """Register the solver class one Python file defines, under its ``name``, for this process and the
    processes it starts (`registry.PluginRegistry.add_file`); returns that name."""
    return SOLVERS.add_file(path)


def names(available_only: bool = False) -> list[str]:
    """Names of the installed solver plugins, sorted.

    Parameters
    ----------
    available_only : bool
        Keep only those whose `availability` is truthy (this loads each plugin's module).
    """
    found = SOLVERS.names()
    return [name for name in found if availability(name)] if available_only else found


def solver_class(name: str) -> type:
    """The plugin class registered as ``name`` (loading its module, not its backend)."""
    return SOLVERS.load(name)


def availability(name: str) -> Availability:
    """Whether solver ``name`` can run here, and why not (load errors included; never raises for them)."""
    return SOLVERS.availability(name)


def get(name: str, **parameters: Any) -> LoadedSolver:
    """Solver ``name``, constructed with ``parameters``, behind the framework's checks (`solvers.load`).

    Raises
    ------
    UnknownSolverError
        No plugin of that name; the message lists the valid names.
    SolverUnavailableError
        The plugin cannot run here (missing package or binary, version mismatch, load error).
    registry.HarnessError
        A parameter the solver does not declare among its settings, or a value out of its range
        (`registry.checked_settings`).
    TypeError
        A parameter the solver does not take (a solver that declares no settings).
    """
    cls = solver_class(name)
    parameters = checked_settings(cls, parameters)
    found = availability(name)
    if not found:
        raise SolverUnavailableError("solver", name, found)
    try:
        return load(cls(**parameters))
    except TypeError as error:
        raise TypeError(f"solver {name!r} does not take parameters {sorted(parameters)}: {error}") from None


def info(selected: Iterable[str] | None = None) -> list[PluginInfo]:
    """Availability, reason, version and class (with its capabilities) of every or each selected solver."""
    return SOLVERS.info(selected)
