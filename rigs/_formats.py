"""The rig format registry: each format says how it is recognised, read and written, and registers itself.

A `RigFormat` names its file suffixes, what a read opens besides the named path (``self_contained``), and
its reader and writer as ``"module:function"`` references imported on first use, so that recognising a
path never imports a format's dependencies (glTF's SciPy graph modules, USD's ``pxr``). `rigs.load`,
`rigs.save` and every command line know formats only through this registry: a new format is one module
that calls `register_format` and one line that imports it (see `rigs._builtin_formats`), or, from an
installed distribution, an entry point in the ``harness.rig_formats`` group naming a `RigFormat` object.

A format from an entry point is a plugin: what it does is checked, never trusted. One that fails to load,
is no `RigFormat` or takes a name already registered (a built-in's) is left out with one warning naming it;
one whose ``claims`` raises claims nothing (a path only it could have read is refused naming it); its reader
runs through `read_with`, which turns whatever it raises or returns that is no valid `Rig` into one
`RigError` naming the plugin; and `rigs.load_with_inputs` records the whole folder of a plugin's rig (a
plugin may open files without `rigs._safe`, which records what the built-in readers open).
"""

from __future__ import annotations

import importlib
import os
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rigs._rig import RigError, RigWarning
from rigs._safe import regular_file

if TYPE_CHECKING:
    from rigs._rig import Rig

#: Entry-point group of rig formats from other distributions (each names a `RigFormat`).
ENTRY_POINT_GROUP = "harness.rig_formats"


@dataclass(frozen=True)
class RigFormat:
    """A rig file format.

    Parameters
    ----------
    name : str
        What ``format=`` and the messages call it (``"obj-folder"``).
    suffixes : tuple of str
        Lower-case file suffixes it reads (``(".gltf", ".glb")``); a folder has none.
    read : str or callable
        ``reader(path, **options) -> Rig``, or ``"module:function"`` naming it. Its keyword-only
        parameters are the format's options (`rigs.load` refuses any other).
    read_for : callable, optional
        ``read_for(path) -> str or callable``: the reader of a path, for a format read differently from a
        folder, an archive and a manifest (then ``read`` is unused and may be ``""``).
    write : str or callable, optional
        ``writer(rig, path) -> Path``, or ``"module:function"``; None for a read-only format.
    write_suffixes : tuple of str
        Suffixes `rigs.save` chooses this format for; ``("",)`` for a folder path without suffix.
    claims : callable, optional
        ``claims(path) -> bool`` for a path its suffix alone does not settle: a folder, or a suffix two
        formats share (a ``.json`` manifest). Without it, a file of one of ``suffixes`` is this format's
        and a folder never is.
    self_contained : tuple of str
        Suffixes of files that a read opens alone; any other path of the format may open files beside
        it (the other OBJs of its folder, a glTF's buffers, a manifest's targets).
    verbatim : bool
        Values are the project's own: `rigs.load` applies no noise floor unless asked (the native archive).
    """

    name: str
    suffixes: tuple[str, ...]
    read: str | Callable[..., Rig]
    read_for: Callable[[Path], str | Callable[..., Rig]] | None = field(default=None, compare=False)
    write: str | Callable[[Rig, Path], Path] | None = None
    write_suffixes: tuple[str, ...] = ()
    claims: Callable[[Path], bool] | None = field(default=None, compare=False)
    self_contained: tuple[str, ...] = ()
    verbatim: bool = False

    def reader(self, path: Path) -> Callable[..., Rig]:
        """The read function of ``path`` (imported now when it is a reference)."""
        return _resolve(self.read if self.read_for is None else self.read_for(path))

    def writer(self) -> Callable[[Rig, Path], Path] | None:
        """The write function, or None for a read-only format."""
        return None if self.write is None else _resolve(self.write)

    def recognises(self, path: Path) -> bool:
        """Whether ``path`` (an existing file or folder) is of this format."""
        if self.claims is not None:
            return (path.is_dir() or path.suffix.lower() in self.suffixes) and self.claims(path)
        return not path.is_dir() and path.suffix.lower() in self.suffixes

    def reads_alone(self, path: Path) -> bool:
        """Whether a read of ``path`` opens that file only (no file beside it)."""
        return not path.is_dir() and path.suffix.lower() in self.self_contained


_FORMATS: dict[str, RigFormat] = {}
#: The entry point (``name = module:attribute``) of each format a plugin registered, by format name.
_PLUGIN_ORIGINS: dict[str, str] = {}
_PLUGINS_LOADED = False


def plugin_origin(rig_format: RigFormat) -> str:
    """``rig format plugin 'xyz' (module:attribute)`` for a format an entry point registered, else ""."""
    origin = _PLUGIN_ORIGINS.get(rig_format.name)
    return "" if origin is None or _FORMATS.get(rig_format.name) is not rig_format else origin


def register_format(rig_format: RigFormat) -> RigFormat:
    """Add ``rig_format`` to the registry (recognised after the built-in formats and those registered
    before it).

    Raises
    ------
    ValueError
        When another format of that name is registered.
    """
    _load_plugins()
    known = _FORMATS.get(rig_format.name)
    if known is not None and known != rig_format:
        raise ValueError(f"rig format {rig_format.name!r} is registered twice")
    _FORMATS[rig_format.name] = rig_format
    return rig_format


def formats() -> tuple[RigFormat, ...]:
    """Every registered format, in the order they are recognised."""
    _load_plugins()
    return tuple(_FORMATS.values())


def rig_format(name: str, path: str | Path) -> RigFormat:
    """The format called ``name``; a `RigError` naming ``path`` and the known formats when none is."""
    _load_plugins()
    if name not in _FORMATS:
        raise RigError(f"{path}: unknown format {name!r} (one of {', '.join(_FORMATS)})")
    return _FORMATS[name]


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
        raise RigError(f"{path}: folder holds no rig of a known format ({', '.join(_FORMATS)})")
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
    from rigs._rig import Rig

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


def _resolve(reference: str | Callable[..., Any]) -> Callable[..., Any]:
    if callable(reference):
        return reference
    module, _, name = reference.partition(":")
    return getattr(importlib.import_module(module), name)


def _load_plugins() -> None:
    """Register the built-in formats, then those of installed distributions' ``harness.rig_formats``
    entry points, once."""
    global _PLUGINS_LOADED
    if _PLUGINS_LOADED:
        return
    _PLUGINS_LOADED = True
    from importlib.metadata import entry_points

    import rigs._builtin_formats  # noqa: F401  (registers them)

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
        if loaded.name in _FORMATS:
            warnings.warn(
                RigWarning(
                    f"{origin} takes the name {loaded.name!r} of a format already registered; left out"
                ),
                stacklevel=3,
            )
            continue
        _FORMATS[loaded.name] = loaded
        _PLUGIN_ORIGINS[loaded.name] = origin
