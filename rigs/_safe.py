"""Reading rig files safely: only regular files inside the rig's folder, never more bytes than they can hold.

Rig files come from other people, and a file names others (a glTF buffer URI, a manifest's list, a folder's
entries). The loaders read through this module, which refuses, with the reason:

* a path that file content gives as absolute, with a ``..`` part, or with a NUL byte;
* anything that resolves (through symbolic links) outside the rig's folder;
* anything that is not a regular file: a FIFO (reading it would block), a device (``/dev/zero`` never
  ends), a socket, a folder, a symbolic link that dangles or loops;
* a file, a gzip stream or an archive member larger than a cap the caller derives from what the content
  can legitimately need (decompression is streamed and stops at the cap);
* arrays that would be much larger than the files they are decoded from (`check_budget`).

Files are opened non-blocking and checked again after opening, so a file swapped for a FIFO between the
check and the read cannot hang the reader. Every file read and every folder searched is told to
`rigs._inputs`, which makes the rig's content digest of them.
"""

from __future__ import annotations

import errno
import json
import os
import stat
import warnings
import zipfile
import zlib
from collections.abc import Callable
from pathlib import Path, PurePosixPath, PureWindowsPath
from typing import Any

from rigs._inputs import note_file, note_listing
from rigs._rig import RigError, RigWarning

#: Arrays decoded from a file may take this many times the file's bytes (sparse morph targets and
#: compressed archives expand; the Face Units archive expands about 20 times) ...
AMPLIFICATION = 64
#: ... and a small file may always decode to this much.
ALLOWANCE = 128 * 2**20
#: Deflate cannot expand data by more than about 1032 times; an archive member claiming more is corrupt.
DEFLATE_RATIO = 1100

_OPEN_FLAGS = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0) | os.O_CLOEXEC


class UnreadableFile(RigError):
    """A file that cannot be read: missing, not a regular file, or resolving outside the rig's folder.

    Attributes
    ----------
    path : Path
    reason : str
        Why, without the path (the message is ``f"{path}: {reason}"``).
    """

    def __init__(self, path: Path | str, reason: str) -> None:
        super().__init__(f"{path}: {reason}")
        self.path = Path(path)
        self.reason = reason


def size_text(count: int) -> str:
    """``count`` bytes in binary units, for messages."""
    value = float(count)
    for unit in ("bytes", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if value < 1024 or unit == "PiB":
            return f"{int(value)} bytes" if unit == "bytes" else f"{value:.1f} {unit}"
        value /= 1024
    raise AssertionError("unreachable")


def _kind(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode):
        return "a character device"
    if stat.S_ISBLK(mode):
        return "a block device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def regular_file(path: Path, root: Path | None = None) -> int:
    """Size of ``path``, which must be a regular file (after symbolic links) inside ``root`` when given.

    Raises
    ------
    RigError
        Naming the path and why it cannot be read: missing, a dangling or looping symbolic link, a FIFO,
        a device, a socket or a folder, or resolving outside ``root``.
    """
    return int(_checked(path, root).st_size)


def _checked(path: Path, root: Path | None) -> os.stat_result:
    """The status of ``path`` once it is known to be a regular file inside ``root`` (see `regular_file`)."""
    try:
        info = os.stat(path)
    except FileNotFoundError:
        if os.path.islink(path):
            raise UnreadableFile(
                path, f"symbolic link to {os.readlink(path)!r}, which does not exist"
            ) from None
        raise UnreadableFile(path, "no such file") from None
    except OSError as error:
        if error.errno == errno.ELOOP:
            raise UnreadableFile(path, "symbolic link loop") from None
        raise UnreadableFile(path, f"cannot be read ({error.strerror or error})") from None
    except ValueError:  # an embedded NUL byte
        raise UnreadableFile(f"{path!s:.200}", "not a valid file name") from None
    if not stat.S_ISREG(info.st_mode):
        raise UnreadableFile(path, f"is {_kind(info.st_mode)}, not a regular file")
    if root is not None:
        inside(root, path)
    return info


def inside(root: Path, path: Path) -> Path:
    """The real path of ``path``; `RigError` when it resolves outside the real path of ``root``."""
    real, base = Path(os.path.realpath(path)), Path(os.path.realpath(root))
    if not real.is_relative_to(base):
        raise UnreadableFile(path, f"resolves to {real}, outside the rig's folder {base}")
    return real


def named_path(root: Path, name: object, origin: str) -> Path:
    """The path ``name``, written in the file ``origin``, relative to the rig's folder ``root``.

    Raises
    ------
    RigError
        When ``name`` is not a non-empty string, holds a NUL byte, is absolute, or has a ``..`` part.
    """
    if not isinstance(name, str) or not name:
        raise RigError(f"{origin}: a file name must be a non-empty string, got {name!r:.80}")
    if "\x00" in name:
        raise RigError(f"{origin}: file name {name!r:.80} holds a NUL byte")
    posix = PurePosixPath(name)
    if posix.is_absolute() or PureWindowsPath(name).drive or name.startswith("\\"):
        raise RigError(f"{origin}: {name!r:.200} is an absolute path; only files inside {root} are read")
    if ".." in posix.parts or ".." in PureWindowsPath(name).parts:
        raise RigError(f"{origin}: {name!r:.200} leaves the folder {root}; only files inside it are read")
    return root / posix


def folder_relative(name: str) -> str | None:
    """``name``, a file reference written in a rig's file (``\\`` read as ``/``), as a relative POSIX path
    that stays inside the referring file's folder, or None when it is absolute, names a drive or climbs out
    with ``..`` (the files a copy of the rig would not carry along)."""
    path = PurePosixPath(name.replace("\\", "/"))
    if path.is_absolute() or not path.parts or ".." in path.parts or ":" in name:
        return None
    return path.as_posix()


def read_bytes(
    path: Path, *, root: Path | None = None, limit: int | None = None, why: str = "", head: bool = False
) -> bytes:
    """The bytes of the regular file ``path`` (inside ``root`` when given), at most ``limit`` of them.

    Parameters
    ----------
    path : Path
    root : Path, optional
        The rig's folder; ``path`` must resolve inside it.
    limit : int, optional
        Largest size accepted; ``why`` says where it comes from, for the message.
    why : str
        E.g. ``"a .target for 52 vertices"``.
    head : bool
        Read only the first ``limit`` bytes of a larger file instead of refusing it.

    Raises
    ------
    RigError
        See :func:`regular_file`; also when the file is larger than ``limit``.
    """
    checked = _checked(path, root)
    size = checked.st_size
    if limit is not None and size > limit and not head:
        raise RigError(
            f"{path}: {size_text(size)}, more than {why or 'the file'} can hold ({size_text(limit)})"
        )
    wanted = size if limit is None else min(size, limit)
    try:
        descriptor = os.open(path, _OPEN_FLAGS)
    except OSError as error:
        raise UnreadableFile(path, f"cannot be read ({error.strerror or error})") from None
    with os.fdopen(descriptor, "rb") as stream:
        opened = os.fstat(descriptor)
        if (opened.st_dev, opened.st_ino) != (checked.st_dev, checked.st_ino):  # replaced since the check
            raise UnreadableFile(path, "was replaced while it was being read")
        try:
            data = stream.read(wanted if head else wanted + 1)
        except OSError as error:
            raise UnreadableFile(path, f"cannot be read ({error.strerror or error})") from None
    if len(data) > wanted:
        raise RigError(f"{path}: grew while it was read")
    note_file(path, data)
    return data


def read_text(path: Path, *, root: Path | None = None, limit: int | None = None, why: str = "") -> str:
    """:func:`read_bytes` decoded as UTF-8 (undecodable bytes replaced, a leading byte-order mark, which
    Windows editors write, dropped)."""
    return read_bytes(path, root=root, limit=limit, why=why).decode("utf-8-sig", errors="replace")


def read_json(path: Path, *, root: Path | None = None, limit: int, what: str) -> Any:
    """The JSON document in the regular file ``path`` of at most ``limit`` bytes (:func:`read_bytes`).

    Parameters
    ----------
    what : str
        What the file is, for messages: ``"manifest"``, ``"regions file"``.

    Raises
    ------
    RigError
        See :func:`read_bytes`; also ``PATH: not a readable JSON WHAT (...)`` for text that is not UTF-8 or
        not JSON, or a document nested deeper than Python's parser follows (a list of lists 100,000 deep).
    """
    data = read_bytes(path, root=root, limit=limit, why=f"a {what}")
    try:
        return json.loads(data.decode("utf-8-sig"))
    except UnicodeDecodeError as error:
        detail = f"not UTF-8: {error.reason} at byte {error.start}"
    except json.JSONDecodeError as error:
        detail = f"{error.msg}, line {error.lineno} column {error.colno}"
    except RecursionError:
        detail = "nested too deeply"
    raise RigError(f"{path}: not a readable JSON {what} ({detail})")


def gunzip(data: bytes, limit: int, label: str, why: str) -> bytes:
    """Decompress gzip ``data`` (one or more members), stopping as soon as the output passes ``limit``.

    Raises
    ------
    RigError
        When ``data`` is empty, not gzip, truncated or corrupt, or inflates past ``limit`` (``why``
        says where the cap comes from).
    """
    if not data:
        raise RigError(f"{label}: empty file, not a gzip stream")
    out = bytearray()
    rest = data
    while rest:
        stream = zlib.decompressobj(16 + zlib.MAX_WBITS)
        try:
            out += stream.decompress(rest, limit + 1 - len(out))
        except zlib.error as error:
            raise RigError(f"{label}: not a valid gzip stream ({error})") from None
        if len(out) > limit:
            raise RigError(f"{label}: inflates past {size_text(limit)}, more than {why} can hold")
        if not stream.eof:
            raise RigError(f"{label}: truncated gzip stream")
        rest = stream.unused_data
    return bytes(out)


def read_member(archive: zipfile.ZipFile, name: str, label: str, limit: int, why: str) -> bytes:
    """The bytes of archive member ``name``, refused when it claims or inflates past ``limit``.

    Raises
    ------
    RigError
        For a member over the cap, compressed beyond what deflate can do, encrypted, or corrupt.
    """
    info = archive.getinfo(name)
    if info.file_size > limit:
        raise RigError(f"{label}: {size_text(info.file_size)}, more than {why} can hold ({size_text(limit)})")
    check_ratio(info, label)
    try:
        with archive.open(info) as stream:
            data = stream.read(limit + 1)
    except (zipfile.BadZipFile, zlib.error, OSError, EOFError, NotImplementedError, RuntimeError) as error:
        raise RigError(f"{label}: corrupt archive member ({error})") from None
    if len(data) > limit:
        raise RigError(f"{label}: inflates past {size_text(limit)}, more than {why} can hold")
    return data


def check_ratio(info: zipfile.ZipInfo, label: str) -> None:
    """Refuse a member stored with a method other than store or deflate, or claiming an impossible ratio."""
    if info.compress_type not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):
        raise RigError(f"{label}: compressed with zip method {info.compress_type} (only store and deflate)")
    largest = (
        info.compress_size if info.compress_type == zipfile.ZIP_STORED else DEFLATE_RATIO * info.compress_size
    )
    if info.file_size > largest + 1024:
        raise RigError(
            f"{label}: claims {size_text(info.file_size)} from {size_text(info.compress_size)} of compressed "
            "data, more than the compression can produce (corrupt archive directory)"
        )


def check_budget(label: str, what: str, nbytes: int, source_bytes: int) -> None:
    """Refuse to allocate ``nbytes`` for ``what`` decoded from files of ``source_bytes`` in all.

    The limit is the larger of `ALLOWANCE` and `AMPLIFICATION` times ``source_bytes``: a file cannot
    legitimately describe arrays far larger than itself (only empty or sparse shapes and compression
    expand, and not by that much), so more is a malformed file or a decompression bomb.
    """
    limit = max(ALLOWANCE, AMPLIFICATION * source_bytes)
    if nbytes > limit:
        raise RigError(
            f"{label}: {what} would take {size_text(nbytes)}, more than {size_text(source_bytes)} of "
            f"rig files can describe (limit {size_text(limit)})"
        )


def rig_entries(folder: Path, wanted: Callable[[str], bool], *, recursive: bool) -> list[Path]:
    """The entries of ``folder`` (and its subfolders when ``recursive``) whose names ``wanted`` accepts.

    Each one must be a regular file inside ``folder`` (see :func:`regular_file`): a shape is never left
    out silently because its file is a dangling or looping link, a FIFO or outside the folder. Symbolic
    links to subfolders are not searched; each one is named in a `RigWarning`.

    Returns
    -------
    Sorted paths.
    """
    found: list[Path] = []
    if recursive:
        walk = os.walk(folder, followlinks=False)
    else:
        with os.scandir(folder) as entries:
            names = [entry.name for entry in entries]
        walk = iter([(str(folder), [], names)])
    for directory, subfolders, files in walk:
        for name in subfolders:
            if os.path.islink(os.path.join(directory, name)):
                warnings.warn(
                    f"{Path(directory) / name}: symbolic link to a folder, not searched for rig files",
                    RigWarning,
                    stacklevel=3,
                )
        for name in [*subfolders, *files]:
            if wanted(name):
                path = Path(directory) / name
                regular_file(path, folder)
                found.append(path)
    note_listing(folder, found, recursive=recursive)
    return sorted(found)
