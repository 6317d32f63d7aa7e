"""The table of registered rig formats and the `RigFormat` type its entries are.

The table only holds formats: filling it is left to its users, so that the built-in formats
(`rigs._builtin_formats`) can enter themselves without importing the module that loads them on first use
(`rigs._formats`, which also loads the formats of entry points and looks formats up for `rigs.load`).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from rigs._rig import Rig


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


#: Every registered format by name, in the order they are recognised.
REGISTERED: dict[str, RigFormat] = {}
#: The entry point (``name = module:attribute``) of each format a plugin registered, by format name.
PLUGIN_ORIGINS: dict[str, str] = {}


def enter(rig_format: RigFormat) -> RigFormat:
    """Add ``rig_format`` to the table, after the formats entered before it.

    Raises
    ------
    ValueError
        When another format of that name is registered.
    """
    known = REGISTERED.get(rig_format.name)
    if known is not None and known != rig_format:
        raise ValueError(f"rig format {rig_format.name!r} is registered twice")
    REGISTERED[rig_format.name] = rig_format
    return rig_format


def plugin_origin(rig_format: RigFormat) -> str:
    """``rig format plugin 'xyz' (module:attribute)`` for a format an entry point registered, else ""."""
    origin = PLUGIN_ORIGINS.get(rig_format.name)
    return "" if origin is None or REGISTERED.get(rig_format.name) is not rig_format else origin


def _resolve(reference: str | Callable[..., Any]) -> Callable[..., Any]:
    if callable(reference):
        return reference
    module, _, name = reference.partition(":")
    return getattr(importlib.import_module(module), name)
