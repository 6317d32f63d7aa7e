"""Output folders that only ever replace or remove files the project wrote itself.

A folder a command writes holds a manifest, ``.harness-manifest.json``::

    {"format": "harness-output-folder", "version": 2,
     "files": {"expressions.json": {"kind": "pack", "sha256": "<hex>", "inode": 1234}, ...}}

listing every file written there (a path relative to the folder, ``/``-separated), the kind of command that
wrote it (``pack``, ``run``, ``instances``, ``report``), the SHA-256 of what it wrote and the inode the file
got when it was written. The inode ties an entry to the file the command made: a copy of the folder, a
manifest copied beside other files or one written by hand lists inodes its files do not have, so none of
them counts as the command's (a version 1 manifest, which lists no inodes, makes no file the command's).
`claim` opens a folder for a command of one kind:

* a new or empty folder is taken;
* a folder holding an earlier output of that kind is refused unless ``force``;
* a folder holding anything else (a file the manifest does not list for this kind, one changed since it was
  written, one that is not the file written there, a link) is always refused, naming what is in the way:
  nothing the command did not write is ever overwritten or removed, and none has to be kept beside a
  replaced output;
* a folder that is, contains or lies inside a protected path (the input rig's file or folder) is always
  refused, so that writing the output can never touch the input (`check_apart`).

A command that writes its output as a whole (`OutputFolder.replace`: ``harness pack``'s session folder,
``harness instances``, a run's report) writes it into a fresh hidden sibling folder,
``.<name>.harness-<random>.tmp``, and renames that into place once every file and the manifest are on disk;
an earlier output is renamed aside first and removed once the new one is in place. Until then the folder is
as it was, whatever stops the command (a full disk, Ctrl-C, a kill). A command that adds its files one by one
to the folder itself (``harness run``, so that ``--resume`` can finish an interrupted run) lists each in
``files`` and saves the manifest (`OutputFolder.save`) before it writes the file atomically;
`OutputFolder.clear` removes an earlier output of it, `OutputFolder.record` lists a file found whole on
resuming.

What a killed command leaves is recognisable by its name (`registry.staged_target`: the word ``harness`` in
it tells it from a user's ``.notes.20241204.tmp``): the sibling folders of an unfinished replacement and the
temporary files of unfinished atomic writes. A folder holding only those counts as empty, and a successful
`claim` removes them.

One process writes a folder at a time: a claim with ``lock`` holds an exclusive ``flock`` on the folder
itself until `OutputFolder.close` (or the process ends, however it ends), taken before the folder is read, so
a second command claiming the same folder, new or not, is refused with one line while the first writes.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import os
import shutil
import stat
import tempfile
import weakref
from collections.abc import Iterable, Mapping
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path, PurePosixPath

from registry._atomic import (
    atomic_write,
    staged_prefix,
    staged_target,
    swap_folder,
    sync_file,
    sync_folders,
)
from registry._errors import HarnessError

MANIFEST_NAME = ".harness-manifest.json"
MANIFEST_FORMAT = "harness-output-folder"
MANIFEST_VERSION = 2
#: Manifest versions read: version 1 listed no inodes (its entries make no file the command's).
READ_VERSIONS = (1, 2)
#: Files flushed to disk at once, beside the making of the next file (`OutputFolder.replace`).
FLUSHING = 4


class OutputFolderError(HarnessError):
    """An output folder a command may not write into, or a file in it the command may not replace."""


def file_sha256(path: Path) -> str:
    """Hex SHA-256 of a file's content, read in blocks."""
    digest = hashlib.sha256()
    with Path(path).open("rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


#: One manifest entry: ``kind``, ``sha256`` and ``inode`` (absent in version 1 manifests).
Entry = dict[str, str | int]


def _flushed(path: Path) -> tuple[str, int]:
    """Flush a file written without it to disk (`registry.sync_file`); returns its SHA-256 and inode."""
    sync_file(path)
    return file_sha256(path), os.stat(path).st_ino


def written_by(entry: Mapping[str, object], path: Path) -> bool:
    """Whether ``path`` is the file a manifest ``entry`` lists: the inode the file got when the command
    wrote it (a copy or another file has another one) and its content unchanged since."""
    try:
        status = os.lstat(path)
    except OSError:
        return False
    if not stat.S_ISREG(status.st_mode) or entry.get("inode") != status.st_ino:
        return False
    return file_sha256(path) == entry["sha256"]


def _write_error(path: Path, error: OSError) -> OutputFolderError:
    return OutputFolderError(
        f"{path}: cannot write ({error.strerror or error}); check the free space and permissions"
    )


class OutputFolder:
    """A claimed output folder (made by `claim`; see the module docstring).

    ``files`` maps each listed file (relative name) to its ``{"kind", "sha256", "inode"}`` entry.
    """

    def __init__(self, path: Path, kind: str, files: dict[str, Entry], lock: int | None = None) -> None:
        self.path = path
        self.kind = kind
        self.files = files
        self._lock = lock
        self._release = None if lock is None else weakref.finalize(self, os.close, lock)

    def close(self) -> None:
        """Release the folder's lock, if the claim took one (idempotent)."""
        if self._release is not None:
            self._release()

    def __enter__(self) -> OutputFolder:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    @property
    def manifest(self) -> Path:
        """The manifest file of the folder."""
        return self.path / MANIFEST_NAME

    def replace(self, contents: Mapping[str, bytes | str] | Iterable[tuple[str, bytes | str]]) -> list[Path]:
        """Make the folder hold exactly ``contents`` (``name -> data``, relative names, text as UTF-8):
        all of them or, when one cannot be written or making them fails, none, the folder as it was.

        The files are written, as they come, into a fresh hidden sibling folder with their manifest; once
        all are on disk, the earlier output is checked again (`claim`'s rules), renamed aside, the new
        folder renamed into its place and the earlier one removed.

        Returns
        -------
        list of Path
            The written files (at their final place), in the order of ``contents``.

        Raises
        ------
        OutputFolderError
            When a name is not a relative file name, comes twice, or is both a file and a folder; when a
            write fails (naming the file and the reason); when the folder was changed meanwhile.
        """
        pairs = contents.items() if isinstance(contents, Mapping) else contents
        parent = self.path.parent
        try:
            staging = Path(tempfile.mkdtemp(prefix=staged_prefix(self.path.name), suffix=".tmp", dir=parent))
        except OSError as error:
            raise _write_error(self.path, error) from None
        try:
            os.chmod(staging, self.path.stat().st_mode & 0o7777)  # (the folder's own, not a private one)
            with ThreadPoolExecutor(FLUSHING) as flushing:
                flushed = self._fill(staging, pairs, flushing)
                files = {}
                for name, future in flushed.items():
                    if future.exception() is not None:
                        raise _write_error(self.path / name, future.exception()) from None
                    sha256, inode = future.result()
                    files[name] = {"kind": self.kind, "sha256": sha256, "inode": inode}
            names = list(files)
            try:
                _flushed(atomic_write(staging / MANIFEST_NAME, _manifest_text(files), sync=False))
            except OSError as error:
                raise _write_error(self.path / MANIFEST_NAME, error) from None
            sync_folders([*(staging / name for name in names), staging / MANIFEST_NAME])
            self._check_unchanged()
            try:
                aside = swap_folder(staging, self.path)
            except OSError as error:
                raise _write_error(self.path, error) from None
        except BaseException:
            shutil.rmtree(staging, ignore_errors=True)
            raise
        if aside is not None:
            shutil.rmtree(aside, ignore_errors=True)
        self.files = files
        return [self.path / name for name in names]

    def _fill(
        self, staging: Path, pairs: Iterable[tuple[str, bytes | str]], flushing: ThreadPoolExecutor
    ) -> dict[str, Future[tuple[str, int]]]:
        """Write ``pairs`` into ``staging`` as they come, each flushed to disk and hashed by ``flushing``
        while the next is made; name -> its SHA-256 and inode to come, in order."""
        flushed: dict[str, Future[tuple[str, int]]] = {}
        folders: set[str] = set()
        for name, data in pairs:
            name = _checked_name(name)
            parents = [str(parent) for parent in PurePosixPath(name).parents][:-1]
            if name in flushed:
                raise OutputFolderError(f"{self.path / name}: given twice in one write")
            if name in folders or any(parent in flushed for parent in parents):
                raise OutputFolderError(f"{self.path / name}: both a file and a folder in one write")
            folders.update(parents)
            payload = data.encode("utf-8") if isinstance(data, str) else bytes(data)
            path = staging / name
            try:
                path.parent.mkdir(parents=True, exist_ok=True)
                atomic_write(path, payload, sync=False)
            except OSError as error:
                raise _write_error(self.path / name, error) from None
            flushed[name] = flushing.submit(_flushed, path)
        return flushed

    def _check_unchanged(self) -> None:
        """The folder, about to be replaced, is still the one claimed, holding only this kind's files."""
        if self._lock is not None:
            try:
                same = os.stat(self.path).st_ino == os.fstat(self._lock).st_ino
            except FileNotFoundError:
                same = False
            if not same:
                raise OutputFolderError(f"{self.path}: was moved or replaced while this command wrote it")
        files, problem = _read_manifest(self.path / MANIFEST_NAME)
        _refuse_foreign(self.path, files, problem, self.kind)

    def record(self, path: Path | str) -> str:
        """List a file already in the folder (e.g. a part file of an interrupted run that read back whole);
        `save` persists the manifest.

        Parameters
        ----------
        path : path
            Inside the folder: absolute, or relative to the folder.

        Returns
        -------
        str
            Its name in the manifest.

        Raises
        ------
        OutputFolderError
            For a path outside the folder, a symbolic link, or anything but a regular file.
        """
        path = Path(path)
        full = path if path.is_absolute() else self.path / path
        try:
            name = full.relative_to(self.path).as_posix()
        except ValueError:
            raise OutputFolderError(f"{full}: not inside the output folder {self.path}") from None
        name = _checked_name(name)
        full = self.path / name
        self._check_inside(name)
        if full.is_symlink() or not full.is_file():
            raise OutputFolderError(f"{full}: not a regular file, so it cannot be recorded as output")
        self.files[name] = {"kind": self.kind, "sha256": file_sha256(full), "inode": full.stat().st_ino}
        return name

    def write(self, name: str, data: bytes) -> Path:
        """Write the file ``name`` of the folder atomically, listed in the manifest (with the inode it gets)
        and the manifest saved *before* it is in place: however the process ends, the folder never holds
        a file the command wrote that the manifest does not list.

        Raises
        ------
        OSError
            When the file cannot be written (it is then as it was).
        OutputFolderError
            When the manifest cannot be saved (the file is then as it was).
        """
        name = _checked_name(name)
        self._check_inside(name)
        sha256 = hashlib.sha256(data).hexdigest()

        def list_it(status: os.stat_result) -> None:
            self.files[name] = {"kind": self.kind, "sha256": sha256, "inode": status.st_ino}
            self.save()

        return atomic_write(self.path / name, data, before_replace=list_it)

    def clear(self) -> list[Path]:
        """Remove this kind's listed files (the earlier output `claim` found only these in) and the folders
        they leave empty, and save the manifest. Returns the removed files."""
        removed = []
        for name in sorted(self.files):
            path = self.path / name
            entry = self.files[name]
            if entry["kind"] == self.kind and self._inside(name) and written_by(entry, path):
                path.unlink()
                removed.append(path)
            del self.files[name]
        for folder in sorted({path.parent for path in removed}, key=lambda path: -len(path.parts)):
            while folder != self.path and self._empty(folder):
                folder.rmdir()
                folder = folder.parent
        self.save()
        return removed

    @staticmethod
    def _empty(folder: Path) -> bool:
        return folder.is_dir() and not folder.is_symlink() and not any(folder.iterdir())

    def _inside(self, name: str) -> bool:
        """Whether ``name``'s folder is inside the output folder (no linked folder leads out of it)."""
        return (self.path / name).parent.resolve() == (self.path.resolve() / name).parent

    def _check_inside(self, name: str) -> None:
        if not self._inside(name):
            raise OutputFolderError(
                f"{self.path / name}: a folder on its path links out of {self.path}; remove the link"
            )

    def save(self) -> Path:
        """Write the manifest (atomically).

        Raises
        ------
        OutputFolderError
            When it cannot be written (naming the file and the reason).
        """
        try:
            return atomic_write(self.manifest, _manifest_text(self.files))
        except OSError as error:
            raise _write_error(self.manifest, error) from error


def _manifest_text(files: Mapping[str, Mapping[str, object]]) -> str:
    document = {"format": MANIFEST_FORMAT, "version": MANIFEST_VERSION, "files": dict(files)}
    return json.dumps(document, indent=2, sort_keys=True) + "\n"


def claim(
    folder: Path, *, kind: str, force: bool, protect: Iterable[Path] = (), lock: bool = False
) -> OutputFolder:
    """Open ``folder`` for a command of ``kind``, creating it (rules in the module docstring); nothing in
    it is replaced or removed here but what killed commands left.

    Parameters
    ----------
    folder : Path
    kind : str
        The command kind (``pack``, ``run``, ...).
    force : bool
        Replace an earlier output of this kind.
    protect : iterable of Path
        Inputs the output must stay apart from: the folder may not be, contain or lie inside any of them.
    lock : bool
        Hold an exclusive lock on the folder until `OutputFolder.close` (the folder is created first).

    Raises
    ------
    OutputFolderError
        One line naming the folder, what is wrong and how to proceed; for a locked claim, also when
        another process holds the folder's lock.
    """
    folder = Path(folder)
    check_apart(folder, protect)
    if folder.is_symlink():
        raise OutputFolderError(
            f"{folder}: is a symbolic link; give the folder it points to, or choose another output folder"
        )
    if folder.exists() and not folder.is_dir():
        raise OutputFolderError(f"{folder}: exists and is not a folder; choose another output folder")
    _make(folder)
    held = _lock(folder) if lock else None
    try:
        files, problem = _read_manifest(folder / MANIFEST_NAME)
        _refuse_foreign(folder, files, problem, kind)
        earlier = sorted(name for name in files if os.path.lexists(folder / name))
        if earlier and not force:
            listed = ", ".join(earlier[:3]) + (", ..." if len(earlier) > 3 else "")
            raise OutputFolderError(
                f"{folder}: holds a harness {kind} ({listed}); use --force to replace it, "
                "or choose another output folder"
            )
        _remove_leftovers(folder, files)
        return OutputFolder(folder, kind, files, held)
    except BaseException:
        if held is not None:
            os.close(held)
        raise


def reopen(folder: Path, *, kind: str) -> OutputFolder:
    """The folder of an unfinished output of ``kind`` to be finished (``harness run --resume``): its
    manifest's entries of this kind as they are (none when it has no manifest), without what killed
    commands left. The caller checks what it reads back (`claim`'s rules are for new outputs)."""
    folder = Path(folder)
    files, _ = _read_manifest(folder / MANIFEST_NAME)
    _remove_leftovers(folder, files)
    return OutputFolder(folder, kind, {name: entry for name, entry in files.items() if entry["kind"] == kind})


def _refuse_foreign(folder: Path, files: Mapping[str, Entry], problem: str, kind: str) -> None:
    """Refuse a folder whose manifest is not one, or that holds anything but ``kind``'s unchanged files."""
    if problem:
        raise OutputFolderError(f"{folder}: {problem}; move it away or choose another output folder")
    foreign = _foreign(folder, files, kind)
    if foreign and not os.path.lexists(folder / MANIFEST_NAME):
        raise OutputFolderError(
            f"{folder}: is not empty and holds no harness output ({_listed(foreign)}); move its files away "
            "or choose another output folder"
        )
    if foreign:
        raise OutputFolderError(
            f"{folder}: holds files harness {kind} did not write or that changed since "
            f"({_listed(foreign)}); move them away or choose another output folder"
        )


def _listed(names: list[str]) -> str:
    return ", ".join(names[:3]) + (", ..." if len(names) > 3 else "")


def _foreign(folder: Path, files: Mapping[str, Entry], kind: str | None) -> list[str]:
    """Names of what in ``folder`` the command of ``kind`` did not write as it is now: files the manifest
    does not list for ``kind`` (any kind for None), that are not the file written there (`written_by`) or
    whose content changed since, links, empty folders and
    anything else. The manifest and the leftovers of killed commands are no such thing, and a subfolder
    with a manifest of its own (a run's report) is judged by that manifest."""
    found = []
    places = _leftover_places(folder, files)
    for root, folders, names in os.walk(folder):
        place = Path(root)
        relative = place.relative_to(folder).as_posix()
        prefix = "" if relative == "." else relative + "/"
        if prefix and not folders and not names:
            found.append(prefix)  # (an empty folder is the user's)
        for name in list(folders):
            path = place / name
            if path.is_symlink():
                found.append(prefix + name)
            elif (path / MANIFEST_NAME).is_file() and not any(
                listed.startswith(f"{prefix}{name}/") for listed in files
            ):
                folders.remove(name)
                nested, problem = _read_manifest(path / MANIFEST_NAME)
                inside = [f"{prefix}{name}/{MANIFEST_NAME}"] if problem else _foreign(path, nested, None)
                found += [f"{prefix}{name}/{entry}" for entry in inside] if not problem else inside
        for name in names:
            path = place / name
            if prefix + name == MANIFEST_NAME or _leftover(path, places):
                continue
            entry = files.get(prefix + name)
            if entry is None or kind not in (None, entry["kind"]) or not written_by(entry, path):
                found.append(prefix + name)
    return sorted(found)


def _regular(path: Path) -> bool:
    return not path.is_symlink() and path.is_file()


def _make(folder: Path) -> None:
    """Create the output ``folder`` (and its parents) unless it exists; a failure is one line."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise OutputFolderError(
            f"{folder}: cannot create the output folder ({error.strerror or error})"
        ) from None


def _lock(folder: Path) -> int:
    """An open descriptor of ``folder`` holding its exclusive ``flock``.

    Raises
    ------
    OutputFolderError
        When another process holds it, or the folder cannot be locked.
    """
    descriptor = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    try:
        fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError as error:
        os.close(descriptor)
        if isinstance(error, BlockingIOError):
            raise OutputFolderError(
                f"{folder}: in use by another harness command writing into it; wait for it to end, or "
                "choose another output folder"
            ) from None
        raise OutputFolderError(f"{folder}: cannot lock the folder ({error.strerror or error})") from None
    return descriptor


def _leftover_places(folder: Path, files: Iterable[str]) -> set[Path] | None:
    """The folders where a file named as staged is a leftover of a killed writer: ``folder`` and the
    folders of its listed ``files``; None (everywhere) when nothing is listed and ``folder`` holds nothing
    but such files. Elsewhere a look-alike is the user's."""
    files = list(files)
    if not files and _only_leftovers(folder):
        return None
    return {folder, *((folder / name).parent for name in files)}


def _leftover(path: Path, places: set[Path] | None) -> bool:
    """Whether ``path`` is a temporary file a killed writer left (a regular file named as staged, in one
    of the ``places``)."""
    return (
        staged_target(path.name) is not None and _regular(path) and (places is None or path.parent in places)
    )


def _only_leftovers(folder: Path) -> bool:
    """Whether ``folder`` holds nothing but files named as staged and folders holding only those."""
    for path in folder.iterdir():
        if path.is_dir() and not path.is_symlink():
            if not _only_leftovers(path):
                return False
        elif not _leftover(path, None):
            return False
    return True


def _remove_leftovers(folder: Path, files: Iterable[str]) -> None:
    """Remove what killed commands left: unfinished replacements of ``folder`` beside it (hidden sibling
    folders named for it), temporary files of atomic writes in it (`_leftover_places`), and the folders
    that leaves empty."""
    with contextlib.suppress(OSError):
        for sibling in folder.parent.iterdir():
            if staged_target(sibling.name) == folder.name and sibling.is_dir() and not sibling.is_symlink():
                shutil.rmtree(sibling, ignore_errors=True)
    places = _leftover_places(folder, files)
    emptied = set()
    for root, _, names in os.walk(folder):
        for name in names:
            if _leftover(Path(root) / name, places):
                (Path(root) / name).unlink(missing_ok=True)
                emptied.add(Path(root))
    for place in sorted(emptied - {folder}, key=lambda path: -len(path.parts)):
        with contextlib.suppress(OSError):
            place.rmdir()


def check_apart(folder: Path, protect: Iterable[Path]) -> None:
    """Refuse an output folder that is, contains or lies inside a protected input path.

    Raises
    ------
    OutputFolderError
        Naming the folder, the input and how they overlap.
    """
    resolved = folder.resolve()
    for guarded in protect:
        target = Path(guarded).resolve()
        if resolved == target:
            relation = "is"
        elif target.is_relative_to(resolved):
            relation = "contains"
        elif resolved.is_relative_to(target):
            relation = "lies inside"
        else:
            continue
        raise OutputFolderError(
            f"{folder}: {relation} the input {guarded}; choose an output folder apart from the inputs"
        )


def _read_manifest(path: Path) -> tuple[dict[str, Entry], str]:
    """The manifest's file entries, and what makes it no manifest ("" when it is one or is missing)."""
    if not os.path.lexists(path):
        return {}, ""
    try:
        if path.is_symlink() or not path.is_file():
            raise ValueError("not a regular file")
        document = json.loads(path.read_text(encoding="utf-8"))
        files = _manifest_files(document)
    except (OSError, UnicodeDecodeError, ValueError, RecursionError, OutputFolderError) as error:
        return {}, f"{MANIFEST_NAME} is not a harness manifest ({_first_line(error)})"
    return files, ""


def _first_line(error: BaseException) -> str:
    if isinstance(error, RecursionError):
        return "nested too deeply"
    lines = str(error).strip().splitlines()
    return lines[0] if lines else type(error).__name__


def _manifest_files(document: object) -> dict[str, Entry]:
    """Validated ``files`` of a manifest document (ValueError naming what is wrong)."""
    if not isinstance(document, dict) or document.get("format") != MANIFEST_FORMAT:
        raise ValueError(f"no 'format': {MANIFEST_FORMAT!r}")
    if document.get("version") not in READ_VERSIONS:
        raise ValueError(f"version {document.get('version')!r}, expected {MANIFEST_VERSION}")
    files = document.get("files")
    if not isinstance(files, dict):
        raise ValueError("'files' is not an object")
    checked = {}
    for name, entry in files.items():
        if not (
            isinstance(entry, dict)
            and isinstance(entry.get("kind"), str)
            and isinstance(entry.get("sha256"), str)
            and type(entry.get("inode", 0)) is int
        ):
            raise ValueError(f"entry {name!r} is not {{'kind': str, 'sha256': str, 'inode': int}}")
        checked[_checked_name(name)] = {
            key: entry[key] for key in ("kind", "sha256", "inode") if key in entry
        }
    return checked


def _checked_name(name: object) -> str:
    """A file name relative to the folder: no absolute path, no ``..``, not the manifest itself."""
    if not isinstance(name, str) or not name or "\\" in name or "\0" in name:
        raise OutputFolderError(f"{name!r} is not a file name inside the output folder")
    pure = PurePosixPath(name)
    if (
        pure.is_absolute()
        or any(part in ("", ".", "..") for part in name.split("/"))
        or name == MANIFEST_NAME
    ):
        raise OutputFolderError(f"{name!r} is not a file name inside the output folder")
    return pure.as_posix()
