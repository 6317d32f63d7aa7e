"""Solver discovery through the ``harness.solvers`` entry-point group (lazy, as networkx's backends).

Listing names reads installed metadata only. Loading a plugin imports its module, which must keep its
heavy library import inside methods; `availability` then asks the class, still without importing the
backend. A plugin whose module fails to import, or that does not look like a `Solver`, is listed as
unavailable with the error; the other plugins are unaffected. Two distributions registering the same
name trigger a warning and the first one found on ``sys.path`` wins.
"""

from __future__ import annotations

import functools
import importlib.metadata
import warnings
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from solvers._base import Availability, Capabilities
from solvers._loaded import LoadedSolver, load

#: Entry-point group that solver plugins register under.
GROUP = "harness.solvers"


class UnknownSolverError(ValueError):
    """No solver plugin of that name is installed."""


class SolverUnavailableError(RuntimeError):
    """The solver plugin is installed but cannot run here; ``availability`` says why."""

    def __init__(self, name: str, availability: Availability) -> None:
        super().__init__(f"solver {name!r} is unavailable ({availability.status}): {availability.reason}")
        self.name = name
        self.availability = availability


@dataclass(frozen=True)
class SolverInfo:
    """What ``harness list`` shows about one solver plugin."""

    name: str
    available: bool
    status: str
    reason: str
    version: str
    capabilities: Capabilities | None
    entry_point: str
    distribution: str

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready mapping (``harness list --json``)."""
        return {
            "name": self.name,
            "available": self.available,
            "status": self.status,
            "reason": self.reason,
            "version": self.version,
            "capabilities": None if self.capabilities is None else self.capabilities.as_dict(),
            "entry_point": self.entry_point,
            "distribution": self.distribution,
        }


def _distribution_name(entry_point: importlib.metadata.EntryPoint) -> str:
    dist = getattr(entry_point, "dist", None)
    return dist.metadata["Name"] if dist is not None else ""


def collect(
    entry_points: Iterable[importlib.metadata.EntryPoint],
) -> dict[str, importlib.metadata.EntryPoint]:
    """Entry points by name; a name registered twice with different targets warns and keeps the first."""
    found: dict[str, importlib.metadata.EntryPoint] = {}
    for entry_point in entry_points:
        first = found.get(entry_point.name)
        if first is None:
            found[entry_point.name] = entry_point
        elif first.value != entry_point.value:
            warnings.warn(
                f"solver {entry_point.name!r} is registered twice: {first.value} "
                f"({_distribution_name(first) or 'unknown distribution'}) and {entry_point.value} "
                f"({_distribution_name(entry_point) or 'unknown distribution'}); using the first",
                RuntimeWarning,
                stacklevel=3,
            )
    return found


@functools.cache
def _entry_points() -> dict[str, importlib.metadata.EntryPoint]:
    return collect(importlib.metadata.entry_points(group=GROUP))


def refresh() -> None:
    """Forget discovered plugins and loaded classes (after installing or removing a plugin)."""
    _entry_points.cache_clear()
    _load.cache_clear()


@functools.cache
def _load(name: str) -> type | Availability:
    """The plugin class, or a load-error `Availability` saying why it could not be loaded."""
    entry_point = _entry_points()[name]
    try:
        cls = entry_point.load()
    except Exception as error:  # any import-time failure of a third-party plugin
        return Availability.load_error(f"cannot load {entry_point.value}: {type(error).__name__}: {error}")
    problems = [
        attribute
        for attribute in ("name", "capabilities", "availability", "solve")
        if not hasattr(cls, attribute)
    ]
    if problems:
        return Availability.load_error(f"{entry_point.value} is not a Solver: it lacks {', '.join(problems)}")
    if not isinstance(cls.capabilities, Capabilities):
        return Availability.load_error(f"{entry_point.value}.capabilities is not a solvers.Capabilities")
    if cls.name != name:
        return Availability.load_error(
            f"{entry_point.value} declares name {cls.name!r}, registered as {name!r}"
        )
    return cls


def names(available_only: bool = False) -> list[str]:
    """Names of the installed solver plugins, sorted.

    Parameters
    ----------
    available_only : bool
        Keep only those whose `availability` is truthy (this loads each plugin's module).
    """
    found = sorted(_entry_points())
    return [name for name in found if availability(name)] if available_only else found


def _check_name(name: str) -> None:
    if name not in _entry_points():
        valid = ", ".join(sorted(_entry_points())) or "none installed"
        raise UnknownSolverError(f"unknown solver {name!r}; valid names: {valid}")


def solver_class(name: str) -> type:
    """The plugin class registered as ``name`` (loading its module, not its backend)."""
    _check_name(name)
    loaded = _load(name)
    if isinstance(loaded, Availability):
        raise SolverUnavailableError(name, loaded)
    return loaded


def availability(name: str) -> Availability:
    """Whether solver ``name`` can run here, and why not (load errors included; never raises for them)."""
    _check_name(name)
    loaded = _load(name)
    if isinstance(loaded, Availability):
        return loaded
    try:
        found = loaded.availability()
    except Exception as error:
        return Availability.load_error(f"{name}.availability() failed: {type(error).__name__}: {error}")
    if not isinstance(found, Availability):
        return Availability.load_error(
            f"{name}.availability() returned {found!r}, not a solvers.Availability"
        )
    return found


def get(name: str, **parameters: Any) -> LoadedSolver:
    """Solver ``name``, constructed with ``parameters``, behind the framework's checks (`solvers.load`).

    Raises
    ------
    UnknownSolverError
        No plugin of that name; the message lists the valid names.
    SolverUnavailableError
        The plugin cannot run here (missing package or binary, version mismatch, load error).
    TypeError
        A parameter the solver does not take.
    """
    cls = solver_class(name)
    found = availability(name)
    if not found:
        raise SolverUnavailableError(name, found)
    try:
        return load(cls(**parameters))
    except TypeError as error:
        raise TypeError(f"solver {name!r} does not take parameters {sorted(parameters)}: {error}") from None


def info(selected: Iterable[str] | None = None) -> list[SolverInfo]:
    """Availability, reason, version and capabilities of every (or each selected) solver plugin."""
    rows = []
    for name in names() if selected is None else list(selected):
        found = availability(name)
        loaded = _load(name)
        entry_point = _entry_points()[name]
        rows.append(
            SolverInfo(
                name=name,
                available=bool(found),
                status=str(found.status),
                reason=found.reason,
                version=found.version,
                capabilities=None if isinstance(loaded, Availability) else loaded.capabilities,
                entry_point=entry_point.value,
                distribution=_distribution_name(entry_point),
            )
        )
    return rows
