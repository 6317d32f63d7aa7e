"""What a rig read opened: every file's bytes and every folder listing a reader relied on.

A rig file may name others (a glTF's buffers, a manifest's targets, the OBJ files beside a neutral, a USD
layer's sublayers and clips), so the content of a rig is the content of everything its read opened, not of
the file named on the command line. The readers open files only through `rigs._safe`, which tells this
module about each file it read and each folder listing it searched while `recording` is active; the
result, `RigInputs`, is the rig's content digest and can say what changed between two reads of it.

Example
-------
>>> with recording(folder) as inputs:  # doctest: +SKIP
...     rig = load(folder / "neutral.obj")
>>> inputs.digest  # doctest: +SKIP
'sha256:...'
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
from collections.abc import Iterable, Iterator
from contextvars import ContextVar
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any


@dataclass
class RigInputs:
    """The files one rig read opened, with the SHA-256 of the bytes read, and the folder listings it used.

    Attributes
    ----------
    root : Path
        The rig's folder; paths are kept relative to it (POSIX spelling).
    files : dict of str to (str, int)
        Relative path -> (hex SHA-256, bytes read), in the order first read. A file read more than once
        keeps the entry of its longest read (a header first, then the whole file).
    listings : dict of str to tuple of str
        Relative folder path (with ``/**`` for a recursive search) -> the sorted relative names of the
        entries the reader accepted there (a shape added beside the others changes the rig).
    argument : str
        The relative name of the file the rig was read from (empty for a folder): the digest leaves its
        name out, so a copy of a rig file under another name is the same rig, while the names of the
        files beside it (shape names, a manifest's entries) count.
    """

    root: Path
    files: dict[str, tuple[str, int]] = field(default_factory=dict)
    listings: dict[str, tuple[str, ...]] = field(default_factory=dict)
    argument: str = ""

    def relative(self, path: Path | str) -> str:
        """``path`` relative to `root` (``../`` parts for a file outside it), POSIX spelling."""
        return Path(os.path.relpath(os.path.abspath(path), os.path.abspath(self.root))).as_posix()

    def add_file(self, path: Path | str, data: bytes | memoryview) -> None:
        """Note that ``data`` was read from ``path``."""
        self.add_digest(path, hashlib.sha256(data).hexdigest(), len(data))

    def add_digest(self, path: Path | str, sha256: str, size: int) -> None:
        """Note that ``size`` bytes of SHA-256 ``sha256`` were read from ``path``."""
        name = self.relative(path)
        entry = (sha256, size)
        previous = self.files.get(name)
        if previous is None or previous[1] < entry[1]:
            self.files[name] = entry

    def add_listing(self, folder: Path | str, entries: Iterable[Path | str], *, recursive: bool) -> None:
        """Note that a reader searched ``folder`` and accepted ``entries``."""
        key = self.relative(folder) + ("/**" if recursive else "")
        self.listings[key] = tuple(sorted(self.relative(entry) for entry in entries))

    def document(self) -> dict[str, Any]:
        """The inputs as JSON-ready data (`from_document` reads it back)."""
        return {
            "argument": self.argument,
            "files": {name: list(entry) for name, entry in self.files.items()},
            "listings": {name: list(entries) for name, entries in self.listings.items()},
        }

    @classmethod
    def from_document(cls, root: Path | str, document: dict[str, Any]) -> RigInputs:
        """The inputs `document` wrote (``root`` is not stored: the rig's folder at the time of reading)."""
        files = {str(k): (str(v[0]), int(v[1])) for k, v in dict(document.get("files", {})).items()}
        listings = {str(k): tuple(map(str, v)) for k, v in dict(document.get("listings", {})).items()}
        return cls(Path(root), files, listings, str(document.get("argument", "")))

    @property
    def digest(self) -> str:
        """``sha256:`` and 64 hex digits over every file's name and hash and every listing, in name order
        (the `argument`'s own name left out)."""
        document = self.document()

        def named(name: str) -> str:
            return "<argument>" if name == self.argument else name

        files = {named(name): entry for name, entry in document["files"].items()}
        listings = {name: [named(entry) for entry in found] for name, found in document["listings"].items()}
        canonical = json.dumps([sorted(files.items()), sorted(listings.items())], separators=(",", ":"))
        return f"sha256:{hashlib.sha256(canonical.encode()).hexdigest()}"

    def changes(self, later: RigInputs) -> list[str]:
        """What differs in ``later``, a read of the same rig: ``face.bin changed``, ``shapes/x.obj is new``,
        ``jawOpen.obj is gone``, ``the entries of . changed (+ a.obj, - b.obj)``; empty when equal."""
        found = []
        for name in sorted(set(self.files) | set(later.files)):
            before, after = self.files.get(name), later.files.get(name)
            if before is None:
                found.append(f"{name} is new")
            elif after is None:
                found.append(f"{name} is no longer read")
            elif before != after:
                found.append(f"{name} changed")
        for name in sorted(set(self.listings) | set(later.listings)):
            was, now = set(self.listings.get(name, ())), set(later.listings.get(name, ()))
            if was != now:
                moved = [f"+ {e}" for e in sorted(now - was)] + [f"- {e}" for e in sorted(was - now)]
                found.append(f"the entries of {name} changed ({', '.join(moved)})")
        return found


_active: ContextVar[RigInputs | None] = ContextVar("rig_inputs", default=None)


@contextlib.contextmanager
def recording(root: Path | str, argument: Path | str | None = None) -> Iterator[RigInputs]:
    """Collect what the rig read from ``argument`` (a file, or None for the folder ``root``) opens inside the
    block (nested blocks collect into their own)."""
    inputs = RigInputs(Path(root))
    if argument is not None:
        inputs.argument = inputs.relative(argument)
    token = _active.set(inputs)
    try:
        yield inputs
    finally:
        _active.reset(token)


#: Most files `record_folder` reads: a plugin's rig in a folder of more is refused (move it to its own).
FOLDER_FILES_MAX = 10_000


def record_folder(folder: Path | str, owner: str) -> None:
    """Record every regular file under ``folder`` (its bytes) and the folder's recursive listing in the
    active `recording` (nothing happens outside one): the content of a rig whose reader may have opened
    any of them (``owner`` names it in messages).

    Raises
    ------
    rigs.RigError
        When the folder holds more than `FOLDER_FILES_MAX` files, or one cannot be read.
    """
    from rigs._rig import RigError

    inputs = _active.get()
    if inputs is None:
        return
    found = []
    for root, folders, names in os.walk(folder):
        folders.sort()
        for name in sorted(names):
            path = Path(root) / name
            if path.is_file() and not path.is_symlink():
                found.append(path)
        if len(found) > FOLDER_FILES_MAX:
            raise RigError(
                f"{folder}: a rig of {owner} is recorded with every file of its folder, and this one holds "
                f"more than {FOLDER_FILES_MAX}; move the rig into a folder of its own"
            )
    for path in found:
        try:
            with path.open("rb") as stream:
                digest = hashlib.file_digest(stream, "sha256")
                inputs.add_digest(path, digest.hexdigest(), stream.tell())
        except OSError as error:
            raise RigError(f"{path}: cannot read it ({error.strerror or error})") from None
    inputs.add_listing(folder, found, recursive=True)


def note_file(path: Path | str, data: bytes | memoryview) -> None:
    """Called by `rigs._safe` for every file it read (nothing happens outside `recording`)."""
    inputs = _active.get()
    if inputs is not None:
        inputs.add_file(path, data)


def note_listing(folder: Path | str, entries: Iterable[Path | str], *, recursive: bool) -> None:
    """Called by `rigs._safe` for every folder search it made (nothing happens outside `recording`)."""
    inputs = _active.get()
    if inputs is not None:
        inputs.add_listing(folder, entries, recursive=recursive)
