"""The code of other commits, ready to be measured: git worktrees and the environment that runs each.

``harness compare --commits`` and ``harness track`` measure commits other than the one running them, as
asv's ``continuous`` and ``run A..B`` do. Each commit is checked out into a git worktree of its own in a
scratch folder (the repository's own working tree is never touched), and its packages run from there:

- **One environment when the dependencies agree.** When every requirement the commit's ``pyproject.toml``
  lists (``dependencies`` and the extras the project installs with ``[all]``) is met by this environment,
  the commit runs with this interpreter and the worktree first on ``PYTHONPATH``. Otherwise a virtual
  environment with exactly those requirements is made once per distinct list, in the user cache
  (``~/.cache/expression-packing/envs/<digest>``), and reused by every commit that lists the same.
- **The commit's own plugins.** Entry points are read from an installed distribution's metadata, and this
  environment's describes the running checkout. So each commit gets a metadata folder of its own
  (``expression_packing_harness-0.dist-info`` with the commit's ``[project.entry-points]``) ahead of
  site-packages on the path: the commit's solvers and transfers are the ones found, its other modules are
  the worktree's.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import tomllib
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

from registry import HarnessError, atomic_write

#: The distribution name the commit's metadata folder stands in for.
DISTRIBUTION = "expression_packing_harness"


class CommitError(HarnessError):
    """A commit that cannot be measured: not in the repository, no project at that commit, or a git error."""


@dataclass(frozen=True)
class CodeVersion:
    """One commit's code and the interpreter that runs it.

    Attributes
    ----------
    name : str
        How tables name it: the ref as given (``HEAD~1``) or the short commit.
    commit : str
        The full commit id.
    python : str
        The interpreter.
    path : tuple of str
        ``PYTHONPATH`` entries, in order: the worktree, then the commit's metadata folder.
    environment : str
        ``this`` when the running environment meets the commit's requirements, else the cached
        environment's folder.
    """

    name: str
    commit: str
    python: str
    path: tuple[str, ...]
    environment: str = "this"

    @property
    def short(self) -> str:
        """The first 10 digits of the commit."""
        return self.commit[:10]


def git(repository: Path, *arguments: str) -> str:
    """The output of ``git -C repository ARGUMENTS`` (stripped).

    Raises
    ------
    CommitError
        When git fails, with its message.
    """
    try:
        done = subprocess.run(
            ["git", "-C", str(repository), *arguments], capture_output=True, text=True, check=False
        )
    except OSError as error:
        raise CommitError(f"git could not run: {error}") from None
    if done.returncode:
        message = (done.stderr or done.stdout).strip().splitlines()
        raise CommitError(f"git {' '.join(arguments)}: {message[-1] if message else 'failed'}")
    return done.stdout.strip()


def repository_of(start: Path) -> Path:
    """The top folder of the git repository holding ``start``.

    Raises
    ------
    CommitError
        When ``start`` is in no git repository.
    """
    try:
        return Path(git(start, "rev-parse", "--show-toplevel"))
    except CommitError:
        raise CommitError(f"{start} is not inside a git repository") from None


def resolve(repository: Path, ref: str) -> str:
    """The full commit id ``ref`` names in ``repository``.

    Raises
    ------
    CommitError
        When ``ref`` names no commit there.
    """
    try:
        return git(repository, "rev-parse", "--verify", "--quiet", f"{ref}^{{commit}}")
    except CommitError:
        raise CommitError(f"{ref!r} names no commit of {repository}") from None


def commit_range(repository: Path, spec: str, *, strict: bool = False) -> list[str]:
    """The commits of ``spec`` oldest first: ``A..B`` (as ``git rev-list``, first parents only) or one ref.

    With ``strict``, ``A`` must be one of ``B``'s ancestors: a range backwards (or between two branches)
    holds no commit between them, or commits that are not.

    Raises
    ------
    CommitError
        When a ref names no commit, or, with ``strict``, ``A`` is not an ancestor of ``B``.
    """
    if ".." not in spec:
        return [resolve(repository, spec)]
    start, _, end = spec.partition("..")
    first, last = resolve(repository, start or "HEAD"), resolve(repository, end or "HEAD")
    if strict and first != last and not _is_ancestor(repository, first, last):
        raise CommitError(f"{spec}: {start or 'HEAD'} is not an ancestor of {end or 'HEAD'}; give OLD..NEW")
    listed = git(repository, "rev-list", "--first-parent", "--reverse", f"{first}..{last}")
    return [first, *listed.split()]


def _is_ancestor(repository: Path, commit: str, descendant: str) -> bool:
    """Whether ``commit`` is an ancestor of ``descendant`` (``git merge-base --is-ancestor``)."""
    try:
        git(repository, "merge-base", "--is-ancestor", commit, descendant)
    except CommitError:
        return False
    return True


def first_parents(repository: Path, tip: str) -> list[str]:
    """``tip`` and all its first parents, oldest first.

    Raises
    ------
    CommitError
        When ``tip`` names no commit.
    """
    return git(repository, "rev-list", "--first-parent", "--reverse", resolve(repository, tip)).split()


@dataclass(frozen=True)
class CommitFacts:
    """What a history records of a commit beside its samples: its id, committer date and subject."""

    commit: str
    date: str
    subject: str


def commit_facts(repository: Path, commit: str) -> CommitFacts:
    """The committer date (ISO 8601) and subject of ``commit``.

    Raises
    ------
    CommitError
        When git cannot show it.
    """
    date, _, subject = git(repository, "show", "-s", "--format=%cI%x00%s", commit).partition("\0")
    return CommitFacts(commit, date, subject)


def add_worktree(repository: Path, commit: str, folder: Path) -> Path:
    """Check ``commit`` out into a new detached worktree at ``folder`` (which must not exist).

    Raises
    ------
    CommitError
        When git cannot, or the commit has no ``pyproject.toml``.
    """
    git(repository, "worktree", "add", "--detach", "--quiet", str(folder), commit)
    if not (folder / "pyproject.toml").is_file():
        remove_worktree(repository, folder)
        raise CommitError(f"commit {commit[:10]} has no pyproject.toml: not a version of this project")
    return folder


def remove_worktree(repository: Path, folder: Path) -> None:
    """Remove a worktree `add_worktree` made (its folder and git's record of it); never raises."""
    try:
        git(repository, "worktree", "remove", "--force", str(folder))
    except CommitError:
        shutil.rmtree(folder, ignore_errors=True)
        try:
            git(repository, "worktree", "prune")
        except CommitError:
            pass


def _project(worktree: Path) -> dict:
    try:
        with (worktree / "pyproject.toml").open("rb") as stream:
            return tomllib.load(stream).get("project") or {}
    except (OSError, tomllib.TOMLDecodeError) as error:
        raise CommitError(f"{worktree / 'pyproject.toml'}: {error}") from None


def requirements(worktree: Path) -> list[str]:
    """The commit's requirements: ``dependencies`` and those of its ``all`` extra, self references
    expanded (``expression-packing-harness[dask,scip]``), sorted."""
    from packaging.requirements import Requirement
    from packaging.utils import canonicalize_name

    project = _project(worktree)
    own = canonicalize_name(project.get("name", DISTRIBUTION))
    extras = project.get("optional-dependencies") or {}
    found: set[str] = set(project.get("dependencies") or [])
    pending, seen = ["all"] if "all" in extras else list(extras), set()
    while pending:
        extra = pending.pop()
        if extra in seen:
            continue
        seen.add(extra)
        for text in extras.get(extra, []):
            requirement = Requirement(text)
            if canonicalize_name(requirement.name) == own:
                pending.extend(requirement.extras)
            else:
                found.add(text)
    return sorted(found)


def unmet(listed: list[str]) -> list[str]:
    """The requirements of ``listed`` this environment does not meet (missing, or another version)."""
    from packaging.requirements import Requirement

    missing = []
    for text in listed:
        requirement = Requirement(text)
        if requirement.marker is not None and not requirement.marker.evaluate():
            continue
        try:
            installed = metadata.version(requirement.name)
        except metadata.PackageNotFoundError:
            missing.append(text)
            continue
        if requirement.specifier and not requirement.specifier.contains(installed, prereleases=True):
            missing.append(text)
    return missing


def write_metadata(worktree: Path, folder: Path) -> Path:
    """A metadata folder holding the commit's entry points (module notes); returns the folder to put on
    the path."""
    project = _project(worktree)
    info = folder / f"{DISTRIBUTION}-0.dist-info"
    info.mkdir(parents=True, exist_ok=True)
    atomic_write(
        info / "METADATA", f"Metadata-Version: 2.1\nName: {project.get('name', DISTRIBUTION)}\nVersion: 0\n"
    )
    lines = []
    for group, entries in sorted((project.get("entry-points") or {}).items()):
        lines.append(f"[{group}]")
        lines.extend(f"{name} = {target}" for name, target in sorted(entries.items()))
        lines.append("")
    scripts = project.get("scripts") or {}
    if scripts:
        lines.append("[console_scripts]")
        lines.extend(f"{name} = {target}" for name, target in sorted(scripts.items()))
    atomic_write(info / "entry_points.txt", "\n".join(lines) + "\n")
    return folder


def environments_folder() -> Path:
    """Where environments for commits with other requirements are kept (the user cache)."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "expression-packing" / "envs"


def environment_for(listed: list[str]) -> Path:
    """The interpreter of a cached environment meeting ``listed`` exactly, made on first use.

    Raises
    ------
    CommitError
        When the environment cannot be made (the last lines pip printed in the message).
    """
    digest = hashlib.sha256("\n".join(listed).encode()).hexdigest()[:16]
    folder = environments_folder() / digest
    python = folder / "bin" / "python"
    if (folder / ".complete").is_file() and python.is_file():
        return python
    shutil.rmtree(folder, ignore_errors=True)
    folder.parent.mkdir(parents=True, exist_ok=True)
    for command in (
        [sys.executable, "-m", "venv", str(folder)],
        [str(python), "-m", "pip", "install", "--quiet", "psutil", *listed],
    ):
        done = subprocess.run(command, capture_output=True, text=True, check=False)
        if done.returncode:
            tail = " | ".join((done.stderr or done.stdout).strip().splitlines()[-3:])
            raise CommitError(
                f"could not make an environment for {len(listed)} requirements in {folder}: {tail}"
            )
    atomic_write(folder / ".complete", "\n".join(listed) + "\n")
    return python


def prepare(repository: Path, ref: str, commit: str, scratch: Path) -> CodeVersion:
    """A worktree of ``commit`` under ``scratch`` and the environment that runs it (module notes).

    Raises
    ------
    CommitError
        When the commit cannot be checked out or its environment cannot be made.
    """
    worktree = add_worktree(repository, commit, scratch / f"tree-{commit[:12]}")
    info = write_metadata(worktree, scratch / f"meta-{commit[:12]}")
    listed = requirements(worktree)
    if unmet(listed):
        python = str(environment_for(listed))
        where = str(Path(python).parent.parent)
    else:
        python, where = sys.executable, "this"
    return CodeVersion(ref, commit, python, (str(worktree), str(info)), where)
