"""Output folders that only ever replace or remove files the harness wrote itself.

A folder the harness writes into holds a manifest, ``.harness-manifest.json``::

    {"format": "harness-output-folder", "version": 1,
     "files": {"expressions.json": {"kind": "pack", "sha256": "<hex>"}, ...}}

listing every file the harness wrote there (a path relative to the folder, ``/``-separated), the kind of
session that wrote it (``pack``, ``run``, ...) and the SHA-256 of what it wrote. The files of one kind are a
*session*. `claim` opens a folder for a session of one kind:

* a new or empty folder is taken;
* a folder holding a session of that kind is refused unless ``force`` (the session is then replaced:
  rewritten files are overwritten, `OutputFolder.remove_stale` removes the leftovers);
* a non-empty folder without a manifest is refused unless ``force`` (its files are then left alone);
* a folder that is, contains or lies inside a protected path (the input rig's file or folder) is always
  refused, so that writing the output can never touch the input (`check_apart`).

Temporary files a killed writer left (named as `registry.stage` names them, `registry.staged_target`) are no
output: a folder holding only those counts as empty, and `claim` removes them from the folder and from the
folders of its listed files (every folder, when nothing else is in the folder).

Whatever ``force`` says, a file is overwritten or removed only when the manifest lists it for this kind
and its content is still what the harness wrote; a file changed since is left in place with a
`ChangedFileWarning`. Every write is atomic (`atomic_write`): a unique temporary file in the same folder,
flushed to disk, then renamed over the target, so a reader never sees half a file. One process writes a
folder's manifest at a time: a claim with ``lock`` holds an exclusive ``flock`` on the folder itself until
`OutputFolder.close` (or the process ends, however it ends), taken before the folder is read, so a second
command claiming the same folder, new or not, is refused with one line while the first writes (it would
otherwise remove the first's staged files as leftovers, and the two would list and place their files over
each other). ``harness run`` holds the same lock of its own (`harness._run.locked`).
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import os
import warnings
import weakref
from collections import deque
from collections.abc import Iterable, Mapping
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path, PurePosixPath

from registry import HarnessError, StagedFile, atomic_write, stage, staged_target, sync_folders

MANIFEST_NAME = ".harness-manifest.json"
MANIFEST_FORMAT = "harness-output-folder"
MANIFEST_VERSION = 1


class OutputFolderError(HarnessError):
    """An output folder the harness may not write into, or a file in it the harness may not replace."""


class ChangedFileWarning(UserWarning):
    """A file the harness wrote was changed since, so it is left in place instead of being removed."""


#: Output files hashed and written at once.
FILE_WRITERS = min(4, os.cpu_count() or 1)
#: Files whose content `OutputFolder.write_files` holds at once while writing contents that come one by
#: one: the next file is made only once the one this many before it is written.
IN_FLIGHT = 2 * FILE_WRITERS


def _sha256(payload: bytes) -> str:
    return hashlib.sha256(payload).hexdigest()


def _write(path: Path, payload: bytes) -> Path:
    """`atomic_write` into the output folder, creating subfolders; a failure is one `OutputFolderError`."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        return atomic_write(path, payload)
    except OSError as error:
        raise _write_error(path, error) from None


def _staged(path: Path, data: bytes | str) -> tuple[StagedFile, str]:
    """`stage` ``data`` beside ``path`` (creating its folder), with the SHA-256 of what was written; a
    failure is one `OutputFolderError`."""
    payload = data.encode("utf-8") if isinstance(data, str) else bytes(data)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        return stage(path, payload), _sha256(payload)
    except OSError as error:
        raise _write_error(path, error) from None


def _write_error(path: Path, error: OSError) -> OutputFolderError:
    return OutputFolderError(
        f"{path}: cannot write ({error.strerror or error}); check the free space and permissions"
    )


def _discard(entries: Iterable[StagedFile]) -> None:
    for entry in entries:
        entry.discard()


def _signature(path: Path) -> tuple[int, int, int] | None:
    """Inode, size and modification time of what is at ``path`` (not following a link); None for nothing."""
    try:
        status = os.lstat(path)
    except FileNotFoundError:
        return None
    return status.st_ino, status.st_size, status.st_mtime_ns


def _missing_folders(path: Path, root: Path, known: Iterable[Path]) -> list[Path]:
    """The folders between ``root`` and ``path`` that do not exist yet (and are not in ``known``),
    outermost first."""
    missing = [folder for folder in path.parents if root in folder.parents and not folder.exists()]
    return [folder for folder in reversed(missing) if folder not in known]


def _remove_empty(folders: Iterable[Path]) -> None:
    """Remove the ``folders`` a failed write made, innermost first, where they are still empty."""
    for folder in sorted(folders, key=lambda path: len(path.parts), reverse=True):
        with contextlib.suppress(OSError):
            folder.rmdir()


def file_sha256(path: Path) -> str:
    """Hex SHA-256 of a file's content, read in blocks."""
    digest = hashlib.sha256()
    with Path(path).open("rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


class OutputFolder:
    """A claimed output folder: writes files atomically and keeps its manifest (see the module docstring).

    Made by `claim`. ``files`` maps each listed file (relative name) to its ``{"kind", "sha256"}`` entry,
    the files of other kinds included.
    """

    def __init__(
        self, path: Path, kind: str, files: dict[str, dict[str, str]], lock: int | None = None
    ) -> None:
        self.path = path
        self.kind = kind
        self.files = files
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

    def write_file(self, name: str, data: bytes | str) -> Path:
        """Write ``data`` as ``name`` (relative to the folder): `write_files` of one file."""
        return self.write_files({name: data})[0]

    def write_files(
        self, contents: Mapping[str, bytes | str] | Iterable[tuple[str, bytes | str]]
    ) -> list[Path]:
        """Write each ``name -> data`` (relative names, text as UTF-8) and list it in the manifest: all of
        them or, when one cannot be written, none.

        The contents may come one by one (pairs from a generator): each file is written to a temporary
        name beside its place (`registry.stage`) and hashed as it comes, several at a time (`FILE_WRITERS`),
        while the next is made (at most `IN_FLIGHT` are held in memory). Once all are written, the
        manifest lists them with their hashes and is saved (once), and only then are they renamed into
        place: a file appears under its name only when the manifest already claims its content, so the
        harness never later replaces or removes a file it did not write. When a file cannot be written
        (e.g. a full disk) or making the contents fails, the staged files are removed and the folder and
        its manifest are as they were.

        Returns
        -------
        list of Path
            The written files, in the order of ``contents``.

        Raises
        ------
        OutputFolderError
            When a name exists and is not this session's unchanged file, comes twice, or a write fails
            (naming the file and the reason; the first failure in order).
        """
        pairs = contents.items() if isinstance(contents, Mapping) else contents
        created: list[Path] = []  # folders this write makes, removed again (when empty) if it fails
        staged: dict[str, tuple[StagedFile, str]] = {}
        earlier: dict[str, dict[str, str] | None] | None = None
        placing: StagedFile | None = None
        written = []
        try:
            staged = self._stage_all(pairs, created)
            names = list(staged)
            earlier = {name: self.files.get(name) for name in names}
            for name in names:
                self.files[name] = {"kind": self.kind, "sha256": staged[name][1]}
            self.save()
            for name in names:
                placing = staged[name][0]
                written.append(placing.commit(sync_folder=False))
        except BaseException as error:
            unplaced = [name for name, (entry, _) in staged.items() if entry.temporary.exists()]
            _discard(staged[name][0] for name in unplaced)
            if earlier is not None:
                self._restore(earlier, unplaced)
            _remove_empty(created)
            if isinstance(error, OSError) and placing is not None:  # (a rename failed)
                raise _write_error(placing.path, error) from None
            raise
        sync_folders(written)
        return written

    def _stage_all(
        self, pairs: Iterable[tuple[str, bytes | str]], created: list[Path]
    ) -> dict[str, tuple[StagedFile, str]]:
        """Name -> (staged file, SHA-256) of every pair, staged as the pairs come (the folders made for
        them are added to ``created``); then every name is checked again where something changed at it
        while the contents were made. On any failure none is left staged and the first failure in order
        (or the failure that stopped the contents) is raised."""
        staging: dict[str, Future[tuple[StagedFile, str]]] = {}
        waiting: deque[Future[tuple[StagedFile, str]]] = deque()
        seen: dict[str, tuple[int, int, int] | None] = {}
        folders: set[str] = set()
        try:
            with ThreadPoolExecutor(FILE_WRITERS) as pool:  # (hashing and writing run outside the lock)
                for name, data in pairs:
                    name = self._checked_new_name(name, staging, folders)
                    path = self.path / name
                    seen[name] = _signature(path)
                    created += _missing_folders(path, self.path, created)
                    staging[name] = pool.submit(_staged, path, data)
                    waiting.append(staging[name])
                    if len(waiting) > IN_FLIGHT:  # (the contents of at most IN_FLIGHT files are held)
                        failure = waiting.popleft().exception()  # waits for the oldest
                        if failure is not None:
                            raise failure
            staged = {name: future.result() for name, future in staging.items()}
            # a file that appeared or changed at a name while the contents were made is checked again
            self.check_free(name for name, before in seen.items() if _signature(self.path / name) != before)
            return staged
        except BaseException:
            _discard(future.result()[0] for future in staging.values() if future.exception() is None)
            raise

    def _checked_new_name(self, name: object, taken: Mapping[str, object], folders: set[str]) -> str:
        """``name`` checked (`_checked_name`, free, inside the folder) and against the names ``taken``
        earlier in the same write and their ``folders`` (a name may not be both a file and a folder)."""
        name = _checked_name(name)
        parents = [str(parent) for parent in PurePosixPath(name).parents][:-1]
        if name in taken:
            raise OutputFolderError(f"{self.path / name}: given twice in one write")
        if name in folders or any(parent in taken for parent in parents):
            raise OutputFolderError(f"{self.path / name}: both a file and a folder in one write")
        folders.update(parents)
        self.check_free([name])
        self._check_inside(name)
        return name

    def _restore(self, earlier: Mapping[str, dict[str, str] | None], names: Iterable[str]) -> None:
        """Give ``names`` back their ``earlier`` entries (none: unlisted) and save the manifest if it can
        be."""
        for name in names:
            if earlier[name] is None:
                del self.files[name]
            else:
                self.files[name] = earlier[name]
        with contextlib.suppress(OutputFolderError):
            self.save()

    def record(self, path: Path | str) -> str:
        """List a file the caller wrote into the folder by other means; `save` persists the manifest.

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
        self.files[name] = {"kind": self.kind, "sha256": file_sha256(full)}
        return name

    def owns(self, name: str) -> bool:
        """Whether ``name`` is this session's file and still holds what the harness wrote."""
        entry = self.files.get(name)
        path = self.path / name
        if entry is None or entry["kind"] != self.kind or not self._inside(name):
            return False
        return not path.is_symlink() and path.is_file() and file_sha256(path) == entry["sha256"]

    def check_free(self, names: Iterable[str]) -> None:
        """Every name is absent or this session's unchanged file (call before writing several files).

        Raises
        ------
        OutputFolderError
            For the first name taken by a file the harness did not write (or that was changed since).
        """
        for name in map(_checked_name, names):
            path = self.path / name
            if os.path.lexists(path) and not self.owns(name):
                raise OutputFolderError(
                    f"{path}: exists and was not written by harness {self.kind} (or was changed since); "
                    "move it away or choose another output folder"
                )

    def remove_stale(self, keep: Iterable[str]) -> list[Path]:
        """Remove this session's listed files not in ``keep`` (e.g. meshes of a longer earlier packing).

        Only files listed for this kind and unchanged since the harness wrote them are removed. A listed
        file that was changed (or replaced by a link or a folder, or reached through a linked folder) is
        left in place with a `ChangedFileWarning` and dropped from the manifest: it is the user's now. The
        manifest is saved.

        Returns
        -------
        list of Path
            The removed files.
        """
        keep = set(keep)
        removed = []
        for name in sorted(self.files):
            if name in keep or self.files[name]["kind"] != self.kind:
                continue
            path = self.path / name
            if self.owns(name):
                path.unlink()
                removed.append(path)
            elif os.path.lexists(path):
                why = "changed since harness " + self.kind + " wrote it" if self._inside(name) else "linked"
                warnings.warn(f"{path}: {why}; left in place", ChangedFileWarning, stacklevel=2)
            del self.files[name]
        self.save()
        return removed

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
        document = {"format": MANIFEST_FORMAT, "version": MANIFEST_VERSION, "files": self.files}
        return _write(self.manifest, (json.dumps(document, indent=2, sort_keys=True) + "\n").encode())


def claim(
    folder: Path, *, kind: str, force: bool, protect: Iterable[Path] = (), lock: bool = False
) -> OutputFolder:
    """Open ``folder`` for a session of ``kind``, creating it (rules in the module docstring).

    Nothing is removed here: replacing a session is `OutputFolder.write_file` over its unchanged files and
    `OutputFolder.remove_stale` for the rest.

    Parameters
    ----------
    folder : Path
    kind : str
        The session kind (``pack``, ``run``, ...).
    force : bool
        Replace a session of this kind, or write beside the files of a folder without a manifest.
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
    if folder.exists() and not folder.is_dir():
        raise OutputFolderError(f"{folder}: exists and is not a folder; choose another output folder")
    if not lock:
        return _claimed(folder, kind, force, None)
    _make(folder)
    held = _lock(folder)
    try:
        return _claimed(folder, kind, force, held)
    except BaseException:
        os.close(held)
        raise


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


def _claimed(folder: Path, kind: str, force: bool, lock: int | None) -> OutputFolder:
    """`claim` once the folder is apart from the inputs (and locked, with ``lock``)."""
    files: dict[str, dict[str, str]] = {}
    if folder.is_dir():
        files, problem = _read_manifest(folder / MANIFEST_NAME)
        if problem and not force:
            raise OutputFolderError(
                f"{folder}: {problem}; choose another output folder, or --force to write beside its files "
                "(harness only ever replaces files it wrote)"
            )
        session = sorted(
            name for name, entry in files.items() if entry["kind"] == kind and os.path.lexists(folder / name)
        )
        if session and not force:
            listed = ", ".join(session[:3]) + (", ..." if len(session) > 3 else "")
            raise OutputFolderError(
                f"{folder}: holds a harness {kind} ({listed}); use --force to replace it, "
                "or choose another output folder"
            )
    _make(folder)
    _remove_leftovers(folder, files)
    return OutputFolder(folder, kind, files, lock)


def _leftover(path: Path) -> bool:
    """Whether ``path`` is a temporary file a killed writer left (a regular file named as staged)."""
    return staged_target(path.name) is not None and path.is_file() and not path.is_symlink()


def _only_leftovers(folder: Path) -> bool:
    """Whether ``folder`` holds nothing but leftover temporary files and folders holding only those."""
    for path in folder.iterdir():
        if path.is_dir() and not path.is_symlink():
            if not _only_leftovers(path):
                return False
        elif not _leftover(path):
            return False
    return True


def _remove_leftovers(folder: Path, files: Mapping[str, object]) -> list[Path]:
    """Remove the leftover temporary files in ``folder`` and in the folders of its listed ``files`` (in a
    folder holding nothing else: in every folder, and the folders they leave empty). Returns the removed
    files."""
    whole = not files and _only_leftovers(folder)
    if whole:
        places = [Path(root) for root, _, _ in os.walk(folder)]
    else:
        places = list(dict.fromkeys([folder, *((folder / name).parent for name in sorted(files))]))
    removed = []
    for place in places:
        if not place.is_dir() or place.is_symlink() or not (place == folder or _inside_folder(folder, place)):
            continue
        for path in sorted(place.iterdir()):
            if _leftover(path):
                path.unlink(missing_ok=True)
                removed.append(path)
    if whole:
        _remove_empty({path.parent for path in removed} - {folder})
    return removed


def _inside_folder(folder: Path, place: Path) -> bool:
    """Whether ``place`` lies inside ``folder`` without a link leading out of it."""
    return place.resolve().is_relative_to(folder.resolve())


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


def _read_manifest(path: Path) -> tuple[dict[str, dict[str, str]], str]:
    """The manifest's file entries, and what makes the folder not ours ("" when it is ours or empty)."""
    folder = path.parent
    if not os.path.lexists(path):
        return {}, "" if _only_leftovers(folder) else "is not empty and holds no harness output"
    try:
        if path.is_symlink() or not path.is_file():
            raise ValueError("not a regular file")
        document = json.loads(path.read_text(encoding="utf-8"))
        files = _manifest_files(document)
    except (OSError, UnicodeDecodeError, ValueError) as error:
        return {}, f"{MANIFEST_NAME} is not a harness manifest ({error})"
    return files, ""


def _manifest_files(document: object) -> dict[str, dict[str, str]]:
    """Validated ``files`` of a manifest document (ValueError naming what is wrong)."""
    if not isinstance(document, dict) or document.get("format") != MANIFEST_FORMAT:
        raise ValueError(f"no 'format': {MANIFEST_FORMAT!r}")
    if document.get("version") != MANIFEST_VERSION:
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
        ):
            raise ValueError(f"entry {name!r} is not {{'kind': str, 'sha256': str}}")
        checked[_checked_name(name)] = {"kind": entry["kind"], "sha256": entry["sha256"]}
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
