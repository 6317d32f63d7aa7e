"""Plugins in one Python file, given by its path (``harness run --solvers ./my_solver.py``), as benchopt
runs a solver file: no distribution, no entry point, no ``pip install``.

A file plugin is registered by the class it defines under that class's ``name``, beside the installed
entry points of its group (`registry.PluginRegistry.add_file`). Registration is written to the environment
variable `PLUGIN_FILES`, so that the worker processes a run starts (fresh interpreters, `solvers.worker`)
discover it as the command did; a run records the file's path and content digest as the plugin's entry
point and version, so that ``--resume`` finds it again and refuses it changed.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import os
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from registry._errors import HarnessError

#: Environment variable holding the plugin files registered so far, for the processes a command starts:
#: a JSON list of ``{"group": ..., "name": ..., "path": ...}``.
PLUGIN_FILES = "HARNESS_PLUGIN_FILES"
#: What a label names when it is a plugin file rather than a registered name.
SUFFIX = ".py"


@dataclass(frozen=True)
class FilePoint:
    """A plugin class in one Python file, standing where an `importlib.metadata.EntryPoint` stands.

    Attributes
    ----------
    name : str
        The class's ``name``, as labels and records name it.
    group : str
        The entry-point group it joins (``harness.solvers``).
    path : str
        The file, an absolute path.
    """

    name: str
    group: str
    path: str
    dist = None

    @property
    def value(self) -> str:
        """The file, where an entry point says ``module:attribute``."""
        return self.path

    @property
    def version(self) -> str:
        """``file`` and the first 12 hex digits of the SHA-256 of the file's bytes: a changed file is
        another version (``--resume`` refuses it)."""
        return f"file {hashlib.sha256(Path(self.path).read_bytes()).hexdigest()[:12]}"

    def load(self) -> Any:
        """The class named `name` among those the file defines.

        Raises
        ------
        HarnessError
            When the file defines no class of that name.
        """
        for plugin in defined_classes(self.path):
            if getattr(plugin, "name", None) == self.name:
                return plugin
        raise HarnessError(f"{self.path} defines no class named {self.name!r} any more")


def defined_classes(path: str, shown: str | None = None) -> list[type]:
    """The classes the Python file ``path`` defines itself (not those it imports), its module executed once
    per process under a name of its own.

    Raises
    ------
    HarnessError
        Naming the file (as ``shown``, by default its path) when it cannot be read or raises on import.
    """
    shown = shown or path
    module_name = f"_harness_plugin_file_{hashlib.sha256(path.encode()).hexdigest()[:16]}"
    module = sys.modules.get(module_name)
    if module is None:
        spec = importlib.util.spec_from_file_location(module_name, path)
        if spec is None or spec.loader is None:
            raise HarnessError(f"{shown}: not a Python file")
        module = importlib.util.module_from_spec(spec)
        sys.modules[module_name] = module  # dataclasses and pickling look their module up by name
        try:
            spec.loader.exec_module(module)
        except Exception as error:  # noqa: BLE001 - any failure of a user's file is told naming it
            del sys.modules[module_name]
            raise HarnessError(f"{shown}: cannot be imported: {type(error).__name__}: {error}") from None
    return [
        value
        for value in vars(module).values()
        if isinstance(value, type) and value.__module__ == module_name
    ]


def recorded(group: str) -> list[FilePoint]:
    """The plugin files of ``group`` registered in this process or the one that started it."""
    return [
        FilePoint(str(entry["name"]), group, str(entry["path"]))
        for entry in _entries()
        if isinstance(entry, dict) and entry.get("group") == group
    ]


def record(point: FilePoint) -> None:
    """Add ``point`` to `PLUGIN_FILES` (once), for the processes this one starts."""
    entries = [entry for entry in _entries() if entry != vars(point)]
    os.environ[PLUGIN_FILES] = json.dumps([*entries, vars(point)])


def _entries() -> list[Any]:
    """The entries of `PLUGIN_FILES` (none when it is unset)."""
    try:
        entries = json.loads(os.environ.get(PLUGIN_FILES) or "[]")
    except ValueError:
        entries = None
    if not isinstance(entries, list):
        raise HarnessError(f"environment variable {PLUGIN_FILES} is not the JSON list it must be")
    return entries
