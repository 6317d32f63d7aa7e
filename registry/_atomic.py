"""Atomic file writes: a file holds either its old content or all of the new one, never a part.

The one writer behind every file the project writes (rigs, fetched rigs, run records, session folders,
report documents, the performance history): a uniquely named temporary file in the same folder, flushed to
disk, renamed over the target (``os.replace``) and the folder's entry flushed too; on any failure the
temporary file is removed and the target is unchanged. A library that writes only to a path of its own
choosing writes to the temporary file of `atomic_path`. A temporary file a killed process left behind is
recognisable by its name (`staged_target`), so that the next writer can remove it. `append_text` is the one
writer that adds to a file instead of replacing it (a line log that a reader cuts at its last whole line),
`move_apart` the one that moves a file aside (never over another), and `swap_folder` puts a whole folder
written beside its place into it. `write_new` is the writer of a file in a store that may be remote (an
fsspec file system): a new file under a new name, never one that exists.
"""

from __future__ import annotations

import errno
import os
import re
import tempfile
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import BinaryIO

from registry._stop import stop_signals_deferred


def _current_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


#: The name a temporary file or folder gets: ``.<name>.harness-<8 random characters>.tmp`` for the file or
#: folder ``<name>`` (the random part is ``tempfile``'s: lowercase letters, digits and ``_``). The word
#: ``harness`` tells it from a user's ``.notes.20241204.tmp``: only what bears it is ever removed as left
#: by a killed writer.
STAGED_NAME = re.compile(r"\.(?P<target>.+)\.harness-[a-z0-9_]{8}\.tmp")

#: Permissions of new files (a temporary file is created private): what ``open()`` would give.
NEW_FILE_MODE = 0o666 & ~_current_umask()


def atomic_write(
    path: str | os.PathLike,
    data: bytes | str | Callable[[BinaryIO], None],
    *,
    sync: bool = True,
    before_replace: Callable[[os.stat_result], None] | None = None,
) -> Path:
    """Write ``data`` to ``path`` atomically.

    Parameters
    ----------
    path : path-like
        The file to create or replace; its folder must exist.
    data : bytes, str or callable
        The content (text is written as UTF-8), or a function that writes it to the binary stream it is
        given (for writers such as ``numpy.savez_compressed`` that stream their output).
    sync : bool
        Flush the content and the folder's entry to disk before this returns. A caller writing many files
        into a folder of its own (not yet in place) passes False, flushes them with `sync_file` (which may
        run beside the making of the next file) and calls `sync_folders` once they are all written.
    before_replace : callable, optional
        Called with the status of the written temporary file (its inode is the one ``path`` will have)
        just before it is renamed over ``path``; an exception it raises leaves ``path`` unchanged (an
        output folder lists a file with its inode before the file is in place).

    Returns
    -------
    Path of the written file. A replaced file keeps its permissions; a new one gets those ``open()``
    would give.

    Raises
    ------
    OSError
        When the folder is not writable or the disk is full (``path`` is then unchanged).
    """
    path = Path(path)
    mode = path.stat().st_mode & 0o777 if path.is_file() else NEW_FILE_MODE
    descriptor, name = tempfile.mkstemp(prefix=staged_prefix(path.name), suffix=".tmp", dir=path.parent)
    try:
        with open(descriptor, "wb") as handle:
            os.fchmod(descriptor, mode)
            if callable(data):
                data(handle)
            else:
                handle.write(data.encode("utf-8") if isinstance(data, str) else bytes(data))
            if sync:
                handle.flush()
                os.fsync(descriptor)
            if before_replace is not None:
                handle.flush()
                before_replace(os.fstat(descriptor))
        os.replace(name, path)
    except BaseException:
        Path(name).unlink(missing_ok=True)
        raise
    if sync:
        _sync_folder(path.parent)
    return path


@contextmanager
def atomic_path(path: str | os.PathLike, *, sync: bool = True) -> Iterator[Path]:
    """A temporary file beside ``path`` to write the new content to; on leaving the block without an
    error it is flushed to disk and renamed over ``path``, on an error it is removed (``path`` unchanged).

    For libraries that write only to a path they are given (``Sdf.Layer.Export``); the temporary file
    exists (empty) when the block starts and is named as `STAGED_NAME` says.

    Raises
    ------
    OSError
        When the folder is not writable or the disk is full.
    """
    path = Path(path)
    mode = path.stat().st_mode & 0o777 if path.is_file() else NEW_FILE_MODE
    descriptor, name = tempfile.mkstemp(prefix=staged_prefix(path.name), suffix=".tmp", dir=path.parent)
    temporary = Path(name)
    try:
        os.close(descriptor)
        yield temporary
        os.chmod(temporary, mode)
        if sync:
            _sync_file(temporary)
        os.replace(temporary, path)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
    if sync:
        _sync_folder(path.parent)


def write_new(filesystem: object, path: str, data: bytes) -> None:
    """Write ``data`` as the new file ``path`` of an fsspec ``filesystem`` (a local folder, an object
    store): written whole under a staged name beside it and moved into place, so that a reader never sees a
    part of it. A local file system gets `atomic_write`.

    Raises
    ------
    FileExistsError
        When ``path`` exists (a store's files are never replaced).
    OSError
        When the store cannot be written.
    """
    if filesystem.exists(path):  # type: ignore[attr-defined]
        raise FileExistsError(f"{path} exists; a store's files are never replaced")
    protocol = getattr(filesystem, "protocol", "")
    if "file" in (protocol if isinstance(protocol, tuple) else (protocol,)):
        filesystem.makedirs(os.path.dirname(path), exist_ok=True)  # type: ignore[attr-defined]
        atomic_write(path, data)
        return
    folder, name = path.rsplit("/", 1) if "/" in path else ("", path)
    staged = f"{folder}/{staged_prefix(name)}{os.urandom(4).hex()}.tmp".lstrip("/")
    filesystem.pipe_file(staged, data)  # type: ignore[attr-defined]
    filesystem.mv(staged, path)  # type: ignore[attr-defined]


def append_text(path: str | os.PathLike, text: str) -> None:
    """Append ``text`` (UTF-8) to ``path`` in one write, flushed before this returns (the process may be
    killed next, leaving at most the end of ``text`` unwritten); ``path`` is created when missing."""
    with open(path, "a", encoding="utf-8") as stream:
        stream.write(text)


def move_apart(path: str | os.PathLike, folder: str | os.PathLike) -> Path:
    """Move the file ``path`` into ``folder`` (created when missing) under its own name, or ``<name>.1``,
    ``<name>.2``, ... when that is taken: never over another file. Returns where it went.

    Raises
    ------
    OSError
        When the folder cannot be made or the file cannot be moved (``path`` then stays).
    """
    path, folder = Path(path), Path(folder)
    folder.mkdir(exist_ok=True)
    target, number = folder / path.name, 1
    while os.path.lexists(target):
        target = folder / f"{path.name}.{number}"
        number += 1
    os.rename(path, target)
    return target


def swap_folder(new: str | os.PathLike, target: str | os.PathLike) -> Path | None:
    """Rename the finished folder ``new`` into the place of the folder ``target`` (a sibling of it).

    An empty ``target`` is replaced in one atomic rename. One with content is first renamed aside, to a
    fresh hidden sibling named as `STAGED_NAME` says, and put back if the second rename fails; that folder
    is returned for the caller to remove. No stop signal cuts the swap short (`stop_signals_deferred`).

    Returns
    -------
    Path or None
        The earlier ``target``, renamed aside; None when ``target`` was empty or missing.

    Raises
    ------
    OSError
        When a rename fails (``target`` is then as it was).
    """
    new, target = Path(new), Path(target)
    with stop_signals_deferred():
        try:
            os.rename(new, target)
            aside = None
        except OSError as error:
            if error.errno not in (errno.ENOTEMPTY, errno.EEXIST):
                raise
            aside = Path(
                tempfile.mkdtemp(prefix=staged_prefix(target.name), suffix=".tmp", dir=target.parent)
            )
            try:
                os.rename(target, aside)
            except BaseException:
                os.rmdir(aside)  # (still the empty folder made for it)
                raise
            try:
                os.rename(new, target)
            except BaseException:
                os.rename(aside, target)
                raise
    _sync_folder(target.parent)
    return aside


def staged_prefix(name: str) -> str:
    """The start of the name of a temporary file or folder for ``name`` (`STAGED_NAME`), for ``tempfile``."""
    return f".{name}.harness-"


def staged_target(name: str) -> str | None:
    """The name of the file a temporary file called ``name`` was written for (None when ``name`` is not
    named as this module names its temporary files)."""
    match = STAGED_NAME.fullmatch(name)
    return None if match is None else match["target"]


def sync_file(path: str | os.PathLike) -> None:
    """Flush a file written with ``atomic_write(..., sync=False)`` to disk (then `sync_folders`).

    Raises
    ------
    OSError
        When it cannot be flushed (e.g. the disk is full); its ``filename`` names the file.
    """
    try:
        _sync_file(Path(path))
    except OSError as error:
        error.filename = str(path)
        raise


def sync_folders(paths: Iterable[str | os.PathLike]) -> None:
    """Flush the folder entries of files written with ``atomic_write(..., sync=False)``, each folder once."""
    for folder in dict.fromkeys(Path(path).parent for path in paths):
        _sync_folder(folder)


def _sync_file(path: Path) -> None:
    descriptor = os.open(path, os.O_RDONLY)
    try:
        os.fsync(descriptor)
    finally:
        os.close(descriptor)


def _sync_folder(folder: Path) -> None:
    """Flush a folder's entries (the rename) to disk where the platform allows it."""
    try:
        descriptor = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(descriptor)
    except OSError:
        pass  # some file systems cannot sync a folder; the rename is still atomic
    finally:
        os.close(descriptor)
