"""A scratch clone of this repository, for the tests that measure commits: the clone shares the objects of
this one (``git clone --local``), so it is made in a moment, and commits made in it touch nothing here."""

from __future__ import annotations

import subprocess
from pathlib import Path

#: This repository.
ROOT = Path(__file__).resolve().parents[1]


def git(folder: Path, *arguments: str) -> str:
    """``git -C folder ARGUMENTS``'s output, stripped (raises on a failure)."""
    return subprocess.run(
        ["git", "-C", str(folder), *arguments], check=True, capture_output=True, text=True
    ).stdout.strip()


def clone(folder: Path) -> Path:
    """A clone of this repository's HEAD at ``folder``, with a committer set; returns ``folder``."""
    subprocess.run(["git", "clone", "--quiet", "--local", str(ROOT), str(folder)], check=True)
    git(folder, "config", "user.email", "tests@example.com")
    git(folder, "config", "user.name", "tests")
    return folder


def commit_all(folder: Path, message: str) -> str:
    """Commit every change in ``folder``; the new commit's id."""
    git(folder, "add", "-A")
    git(folder, "commit", "-qm", message)
    return git(folder, "rev-parse", "HEAD")


def replace_entry_point(folder: Path, old: str, new: str) -> None:
    """Point an entry point of the clone's ``pyproject.toml`` elsewhere (``old`` must be in it)."""
    pyproject = folder / "pyproject.toml"
    text = pyproject.read_text()
    assert old in text, f"{old!r} is not in {pyproject}"
    pyproject.write_text(text.replace(old, new))
