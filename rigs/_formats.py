"""The rig format registry: each format says how it is recognised, read and written, and registers itself.

A `RigFormat` (`rigs._format_table`) names its file suffixes, what a read opens besides the named path
(``self_contained``), and its reader and writer as ``"module:function"`` references imported on first use,
so that recognising a path never imports a format's dependencies (glTF's SciPy graph modules, USD's
``pxr``). `rigs.load`, `rigs.save` and every command line know formats only through this registry: a new
format is one module that calls `register_format` and one line that imports it (the built-in ones enter
the table in `rigs._builtin_formats`, which this module loads on first use), or, from an installed
distribution, an entry point in the ``harness.rig_formats`` group naming a `RigFormat` object.

A format from an entry point is a plugin: what it does is checked, never trusted. One that fails to load,
is no `RigFormat` or takes a name already registered (a built-in's) is left out with one warning naming it;
one whose ``claims`` raises claims nothing (a path only it could have read is refused naming it); its reader
runs through `read_with`, which turns whatever it raises or returns that is no valid `Rig` into one
`RigError` naming the plugin; and `rigs.load_with_inputs` records the whole folder of a plugin's rig (a
plugin may open files without `rigs._safe`, which records what the built-in readers open).
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

from rigs import _format_table as table
from rigs._format_table import RigFormat, plugin_origin
from rigs._rig import Rig, RigError, RigWarning
from rigs._safe import regular_file

#: Entry-point group of rig formats from other distributions (each names a `RigFormat`).
ENTRY_POINT_GROUP = "harness.rig_formats"
_PLUGINS_LOADED = False


def register_format(rig_format: RigFormat) -> RigFormat:
    """Add ``rig_format`` to the registry (recognised after the built-in formats and those registered
    before it).

    Raises
    ------
    ValueError
        When another format of that name is registered.
    """
    _load_plugins()
    return table.enter(rig_format)


def formats() -> tuple[RigFormat, ...]:
    """Every registered format, in the order they are recognised."""
    _load_plugins()
    return tuple(table.REGISTERED.values())


def rig_format(name: str, path: str | Path) -> RigFormat:
    """The format called ``name``; a `RigError` naming ``path`` and the known formats when none is."""
    _load_plugins()
    if name not in table.REGISTERED:
        raise RigError(f"{path}: unknown format {name!r} (one of {', '.join(table.REGISTERED)})")
    return table.REGISTERED[name]


def detect_format(path: str | Path) -> RigFormat:
    """The format of an existing file or folder; a `RigError` when it is none of the registered ones."""
    path = Path(path)
    if not os.path.lexists(path):
        raise RigError(f"{path}: no such file or folder")
    if not path.is_dir():
        regular_file(path)  # a dangling link, a FIFO or a device is named as such
    failed = []
    for candidate in formats():
        try:
            if candidate.recognises(path):
                return candidate
        except Exception as error:  # noqa: BLE001 - a plugin's claims: it claims nothing, the others go on
            if not plugin_origin(candidate):
                raise
            failed.append(f"{plugin_origin(candidate)} failed recognising it: {_described(error)}")
    if failed:
        raise RigError(f"{path}: {failed[0]}")
    if path.is_dir():
        raise RigError(f"{path}: folder holds no rig of a known format ({', '.join(table.REGISTERED)})")
    suffix = path.suffix.lower()
    known = sorted({suffix for candidate in formats() for suffix in candidate.suffixes})
    raise RigError(
        f"{path}: unknown rig format {suffix or '(no suffix)'!r} ({', '.join(known)}, or a folder of a rig)"
    )


def format_for_writing(path: Path) -> RigFormat:
    """The format `rigs.save` writes ``path`` in, by its suffix (a folder path has none)."""
    suffix = "" if path.is_dir() else path.suffix.lower()
    for candidate in formats():
        if candidate.write is not None and suffix in candidate.write_suffixes:
            return candidate
    usable = sorted(
        {
            suffix or "a folder"
            for candidate in formats()
            if candidate.write
            for suffix in candidate.write_suffixes
        }
    )
    raise RigError(f"{path}: cannot save as {path.suffix!r}; use {', '.join(usable)}")


def reader_of(kind: RigFormat, path: Path) -> Callable[..., Rig]:
    """``kind.reader(path)``; for a plugin format, failing to find its reader is one `RigError` naming it."""
    origin = plugin_origin(kind)
    if not origin:
        return kind.reader(path)
    try:
        reader = kind.reader(path)
    except Exception as error:  # noqa: BLE001 - the plugin's failure, told as one line naming it
        raise RigError(f"{path}: {origin} has no reader for it: {_described(error)}") from None
    if not callable(reader):
        raise RigError(f"{path}: {origin} has no reader for it: {reader!r} is not callable")
    return reader


def write_with(kind: RigFormat, rig: Rig, path: Path) -> Path:
    """Write ``rig`` to ``path`` in format ``kind``; a plugin writer's failure is one `RigError` naming it.

    Raises
    ------
    RigError
        For a read-only format, or a writer that fails (a plugin's, whatever it raises).
    """
    origin = plugin_origin(kind)
    try:
        writer = kind.writer()
        if writer is None:
            raise RigError(f"{path}: cannot save format {kind.name!r}: it is read only")
        return Path(writer(rig, path))
    except RigError:
        raise
    except Exception as error:  # noqa: BLE001 - a plugin's failure, told as one line naming it
        if not origin:
            raise
        raise RigError(f"{path}: {origin} failed writing it: {_described(error)}") from None


def read_with(kind: RigFormat, reader: Callable[..., Rig], path: Path, options: dict[str, Any]) -> Rig:
    """``reader(path, **options)``: for a plugin format, whatever it raises (but a `RigError`) and whatever
    it returns but a valid `Rig` (checked again, as a rig made with `dataclasses.replace` is) is one
    `RigError` naming the plugin; a built-in reader's result is returned as it is."""
    origin = plugin_origin(kind)
    if not origin:
        return reader(path, **options)
    try:
        rig = reader(path, **options)
    except RigError:
        raise
    except Exception as error:  # noqa: BLE001 - the plugin's failure, told as one line naming it
        raise RigError(f"{path}: {origin} failed reading it: {_described(error)}") from None
    if not isinstance(rig, Rig):
        raise RigError(f"{path}: {origin} returned {type(rig).__name__}, not a rigs.Rig")
    try:
        return replace(rig)  # (a Rig made without its checks is checked now)
    except RigError as error:
        raise RigError(f"{path}: {origin} returned a rig that is not valid: {error}") from None
    except Exception as error:  # noqa: BLE001 - fields of types no Rig has
        raise RigError(f"{path}: {origin} returned a rig that is not valid: {_described(error)}") from None


def _described(error: BaseException) -> str:
    lines = str(error).strip().splitlines()
    return f"{type(error).__name__}: {lines[0]}" if lines else type(error).__name__


def _load_plugins() -> None:
    """Register the built-in formats, then those of installed distributions' ``harness.rig_formats``
    entry points, once."""
    global _PLUGINS_LOADED
    if _PLUGINS_LOADED:
        return
    _PLUGINS_LOADED = True
    from importlib.metadata import entry_points

    import rigs._builtin_formats  # noqa: F401  (enters them in the table)

    for entry in entry_points(group=ENTRY_POINT_GROUP):
        origin = f"rig format plugin {entry.name!r} ({entry.value})"
        try:
            loaded = entry.load()
        except Exception as error:  # noqa: BLE001 - a broken plugin must not break the formats that work
            warnings.warn(RigWarning(f"{origin} not loaded: {_described(error)}"), stacklevel=3)
            continue
        if not isinstance(loaded, RigFormat):
            warnings.warn(RigWarning(f"{origin} is not a RigFormat, left out"), stacklevel=3)
            continue
        if loaded.name in table.REGISTERED:
            warnings.warn(
                RigWarning(
                    f"{origin} takes the name {loaded.name!r} of a format already registered; left out"
                ),
                stacklevel=3,
            )
            continue
        table.REGISTERED[loaded.name] = loaded
        table.PLUGIN_ORIGINS[loaded.name] = origin
