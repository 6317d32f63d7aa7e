"""Plugins of one entry-point group, discovered lazily (as networkx's backends).

Listing names reads installed metadata only. Loading a plugin imports its module, which keeps its heavy
library import inside methods; `PluginRegistry.availability` then asks the class, still without importing
the backend, and gives it `PROBE_SECONDS` to answer: one that does not is listed as unavailable, saying so,
and is not asked again in the process. A plugin whose module fails to import, or that lacks what its kind
needs, is listed as unavailable with the error; the other plugins are unaffected. Two distributions
registering one name trigger a warning, and the first found on ``sys.path`` wins. A plugin may also be one
Python file, given by its path (`PluginRegistry.add_file`, `registry._plugin_files`).
"""

from __future__ import annotations

import dataclasses
import functools
import importlib.metadata
import threading
import warnings
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from registry._availability import Availability
from registry._errors import HarnessError
from registry._plugin_files import FilePoint, defined_classes, record, recorded

#: Seconds a plugin's ``availability()`` may take to answer (it is meant to be cheap: no backend import).
PROBE_SECONDS = 5.0


class UnknownPluginError(HarnessError):
    """No plugin of that name is installed; the message lists the valid names."""


class PluginUnavailableError(HarnessError):
    """The plugin is installed but cannot run here; ``availability`` says why."""

    def __init__(self, kind: str, name: str, availability: Availability) -> None:
        super().__init__(f"{kind} {name!r} is unavailable ({availability.status}): {availability.reason}")
        self.name = name
        self.availability = availability


@dataclass(frozen=True)
class PluginInfo:
    """What ``harness list`` shows about one plugin, and what a run records of it.

    Attributes
    ----------
    kind : str
        ``solver``, ``transfer method``, ``command``.
    name : str
    available : bool
    status, reason, version : str
        Of its `Availability`.
    entry_point : str
        ``module:attribute``.
    distribution : str
        The installed distribution that registers it (empty when unknown).
    plugin : object or None
        The loaded class (None when it failed to load).
    """

    kind: str
    name: str
    available: bool
    status: str
    reason: str
    version: str
    entry_point: str
    distribution: str
    plugin: Any = None

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready mapping; a plugin's ``capabilities`` (solvers) or traits (transfer methods) included."""
        capabilities = getattr(self.plugin, "capabilities", None)
        return {
            "name": self.name,
            "available": self.available,
            "status": self.status,
            "reason": self.reason,
            "version": self.version,
            "capabilities": None if capabilities is None else capabilities.as_dict(),
            "entry_point": self.entry_point,
            "distribution": self.distribution,
        }


#: What a kind checks on a loaded class: None when it is fine, else what is wrong.
Check = Callable[[Any, str], str | None]


class PluginRegistry:
    """The plugins registered in one entry-point group.

    Parameters
    ----------
    group : str
        Entry-point group, e.g. ``harness.solvers``.
    kind : str
        What a plugin is, for messages (``solver``, ``transfer method``).
    check : callable(plugin, name) -> str or None, optional
        What the kind requires of a loaded plugin; the returned text makes it unavailable.
    unknown, unavailable : exception classes
        Raised for an unknown name and by `load` for a plugin that cannot run (subclasses of
        `UnknownPluginError` and `PluginUnavailableError`).
    """

    def __init__(
        self,
        group: str,
        kind: str,
        check: Check | None = None,
        *,
        unknown: type[UnknownPluginError] = UnknownPluginError,
        unavailable: type[PluginUnavailableError] = PluginUnavailableError,
    ) -> None:
        self.group, self.kind, self._check = group, kind, check
        self._unknown, self._unavailable = unknown, unavailable
        self._loaded = functools.cache(self._load_entry)
        self._silent: dict[str, Availability] = {}

    @functools.cached_property
    def _points(self) -> dict[str, importlib.metadata.EntryPoint | FilePoint]:
        points: dict[str, importlib.metadata.EntryPoint | FilePoint] = dict(
            collect(importlib.metadata.entry_points(group=self.group), self.kind)
        )
        points.update((point.name, point) for point in recorded(self.group))
        return points

    def add_file(self, path: str | Path) -> str:
        """Register the one plugin class a Python file defines, under the class's ``name``, for this
        process and the processes it starts (`registry._plugin_files`).

        Returns
        -------
        str
            The name it is registered under.

        Raises
        ------
        HarnessError
            Naming the file: it is missing or fails to import, it defines no plugin of this kind or more
            than one (with what each candidate lacks), or its plugin takes an installed plugin's name.
        """
        resolved = Path(path).expanduser().resolve()
        if not resolved.is_file():
            raise HarnessError(f"{path}: no such {self.kind} file")
        candidates = defined_classes(str(resolved), str(path))
        problems = {
            cls.__name__: self._check(cls, str(getattr(cls, "name", ""))) if self._check else None
            for cls in candidates
        }
        found = [cls for cls in candidates if problems[cls.__name__] is None]
        if not found:
            told = "; ".join(f"{name} {problem}" for name, problem in problems.items())
            raise HarnessError(f"{path}: defines no {self.kind} class" + (f" ({told})" if told else ""))
        if len(found) > 1:
            many = ", ".join(cls.__name__ for cls in found)
            raise HarnessError(
                f"{path}: defines {len(found)} {self.kind} classes ({many}): keep one per file"
            )
        point = FilePoint(str(found[0].name), self.group, str(resolved))
        installed = self._points.get(point.name)
        if installed is not None and not (isinstance(installed, FilePoint) and installed == point):
            raise HarnessError(
                f"{path}: its {self.kind} is named {point.name!r}, as the one of {installed.value}; rename it"
            )
        record(point)
        self.refresh()
        return point.name

    def refresh(self) -> None:
        """Forget discovered plugins and loaded classes (after installing or removing a plugin)."""
        self.__dict__.pop("_points", None)
        self._loaded.cache_clear()
        self._silent.clear()

    def names(self) -> list[str]:
        """Names of the installed plugins, sorted (no plugin module is imported)."""
        return sorted(self._points)

    def entry_point(self, name: str) -> importlib.metadata.EntryPoint | FilePoint:
        """The entry point registered as ``name``.

        Raises
        ------
        UnknownPluginError
            No plugin of that name; the message lists the valid names.
        """
        if name not in self._points:
            valid = ", ".join(self.names()) or "none installed"
            raise self._unknown(f"unknown {self.kind} {name!r}; valid names: {valid}")
        return self._points[name]

    def load(self, name: str) -> Any:
        """The plugin registered as ``name`` (its module imported, not its backend).

        Raises
        ------
        UnknownPluginError
        PluginUnavailableError
            When it fails to load or lacks what its kind requires.
        """
        loaded = self._loaded(self.entry_point(name))
        if isinstance(loaded, Availability):
            raise self._unavailable(self.kind, name, loaded)
        return loaded

    def availability(self, name: str) -> Availability:
        """Whether plugin ``name`` can run here and why not (load errors included; never raised).

        A plugin without an ``availability()`` of its own is available when it loads, in the version of
        the distribution that registers it; a plugin file's version ends with the file's digest, whatever its
        class answers, so that a changed file is another version (``--resume`` refuses it).
        """
        point = self.entry_point(name)
        found = self._availability(name, point)
        if isinstance(point, FilePoint) and found:
            own = f"{found.version}, " if found.version else ""
            return dataclasses.replace(found, version=own + point.version)
        return found

    def _availability(self, name: str, point: importlib.metadata.EntryPoint | FilePoint) -> Availability:
        loaded = self._loaded(point)
        if isinstance(loaded, Availability):
            return loaded
        if not hasattr(loaded, "availability"):
            return Availability.available(_distribution_version(point))
        if name in self._silent:
            return self._silent[name]
        answer = _within(loaded.availability, PROBE_SECONDS, f"{self.kind} {name} availability")
        if answer is None:
            self._silent[name] = Availability.load_error(
                f"{name}.availability() did not answer within {PROBE_SECONDS:g} s"
            )
            return self._silent[name]
        found, error = answer
        if error is not None:  # a third-party plugin's failure is its reason
            return Availability.load_error(f"{name}.availability() failed: {type(error).__name__}: {error}")
        if not isinstance(found, Availability):
            return Availability.load_error(f"{name}.availability() returned {found!r}, not an Availability")
        return found

    def info(self, selected: Iterable[str] | None = None) -> list[PluginInfo]:
        """Availability, version and the loaded class of every (or each selected) plugin."""
        rows = []
        for name in self.names() if selected is None else list(selected):
            point, found = self.entry_point(name), self.availability(name)
            loaded = self._loaded(point)
            rows.append(
                PluginInfo(
                    kind=self.kind,
                    name=name,
                    available=bool(found),
                    status=str(found.status),
                    reason=found.reason,
                    version=found.version,
                    entry_point=point.value,
                    distribution=_distribution_name(point),
                    plugin=None if isinstance(loaded, Availability) else loaded,
                )
            )
        return rows

    def _load_entry(self, point: importlib.metadata.EntryPoint | FilePoint) -> Any:
        """The plugin, or a load-error `Availability` saying why it could not be loaded."""
        try:
            plugin = point.load()
        except Exception as error:  # noqa: BLE001 - any import-time failure of a third-party plugin
            return Availability.load_error(f"cannot load {point.value}: {type(error).__name__}: {error}")
        problem = None if self._check is None else self._check(plugin, point.name)
        return Availability.load_error(f"{point.value} {problem}") if problem else plugin


def _within(call: Callable[[], Any], seconds: float, what: str) -> tuple[Any, Exception | None] | None:
    """``call()``'s result (and None), or None and the exception it raised, when it answers within
    ``seconds``; None when it does not (it goes on in a daemon thread, never awaited)."""
    outcome: list[tuple[Any, Exception | None]] = []

    def run() -> None:
        try:
            outcome.append((call(), None))
        except Exception as error:  # noqa: BLE001 - handed to the caller
            outcome.append((None, error))

    thread = threading.Thread(target=run, name=what, daemon=True)
    thread.start()
    thread.join(seconds)
    return outcome[0] if outcome else None


def collect(
    entry_points: Iterable[importlib.metadata.EntryPoint], kind: str = "plugin"
) -> dict[str, importlib.metadata.EntryPoint]:
    """Entry points by name; a name registered twice with different targets warns and keeps the first."""
    found: dict[str, importlib.metadata.EntryPoint] = {}
    for entry_point in entry_points:
        first = found.get(entry_point.name)
        if first is None:
            found[entry_point.name] = entry_point
        elif first.value != entry_point.value:
            warnings.warn(
                f"{kind} {entry_point.name!r} is registered twice: {first.value} "
                f"({_distribution_name(first) or 'unknown distribution'}) and {entry_point.value} "
                f"({_distribution_name(entry_point) or 'unknown distribution'}); using the first",
                RuntimeWarning,
                stacklevel=3,
            )
    return found


def missing_attributes(plugin: Any, required: Iterable[str]) -> str | None:
    """``lacks a, b`` naming the attributes ``plugin`` lacks, else None (for a kind's check)."""
    absent = [attribute for attribute in required if not hasattr(plugin, attribute)]
    return f"lacks {', '.join(absent)}" if absent else None


def _distribution_name(entry_point: importlib.metadata.EntryPoint | FilePoint) -> str:
    dist = getattr(entry_point, "dist", None)
    return dist.metadata["Name"] if dist is not None else ""


def _distribution_version(entry_point: importlib.metadata.EntryPoint | FilePoint) -> str:
    dist = getattr(entry_point, "dist", None)
    return dist.version if dist is not None else ""
