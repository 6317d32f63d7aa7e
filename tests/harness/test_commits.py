"""`harness._commits`: other commits' code checked out into worktrees of their own, each run by an
environment that meets its requirements, with its own plugins found."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from harness._commits import (
    CommitError,
    add_worktree,
    commit_range,
    prepare,
    remove_worktree,
    requirements,
    resolve,
    unmet,
    write_metadata,
)

PYPROJECT = """[project]
name = "expression-packing-harness"
dependencies = ["numpy>=1.0"]

[project.optional-dependencies]
fast = ["scipy>=1.0"]
all = ["expression-packing-harness[fast]", "numpy>=1.0"]

[project.entry-points."harness.solvers"]
mine = "mine:Solver"
"""


def _git(folder: Path, *arguments: str) -> str:
    return subprocess.run(
        ["git", "-C", str(folder), *arguments], check=True, capture_output=True, text=True
    ).stdout.strip()


@pytest.fixture
def repository(tmp_path: Path) -> Path:
    """A repository of three commits: no project yet, a project, a change of it."""
    folder = tmp_path / "repo"
    folder.mkdir()
    _git(folder, "init", "-q")
    _git(folder, "config", "user.email", "t@t")
    _git(folder, "config", "user.name", "t")
    (folder / "notes.txt").write_text("no project yet\n")
    _git(folder, "add", "-A")
    _git(folder, "commit", "-qm", "notes")
    (folder / "pyproject.toml").write_text(PYPROJECT)
    (folder / "mine.py").write_text("VALUE = 1\n")
    _git(folder, "add", "-A")
    _git(folder, "commit", "-qm", "project")
    (folder / "mine.py").write_text("VALUE = 2\n")
    _git(folder, "commit", "-qam", "change")
    return folder


def test_refs_and_ranges_name_commits_oldest_first(repository):
    head = resolve(repository, "HEAD")
    assert len(head) == 40 and resolve(repository, "HEAD~1") != head
    assert commit_range(repository, "HEAD~2..HEAD") == [resolve(repository, f"HEAD~{i}") for i in (2, 1, 0)]
    assert commit_range(repository, "HEAD") == [head]
    with pytest.raises(CommitError, match="'nosuch' names no commit"):
        resolve(repository, "nosuch")


def test_a_worktree_holds_the_commit_and_leaves_the_working_tree_alone(repository, tmp_path):
    (repository / "mine.py").write_text("VALUE = 'uncommitted'\n")
    tree = add_worktree(repository, resolve(repository, "HEAD~1"), tmp_path / "tree")
    assert (tree / "mine.py").read_text() == "VALUE = 1\n"
    assert (repository / "mine.py").read_text() == "VALUE = 'uncommitted'\n"
    remove_worktree(repository, tree)
    assert not tree.exists() and str(tree) not in _git(repository, "worktree", "list")


def test_a_commit_without_a_project_is_refused(repository, tmp_path):
    with pytest.raises(CommitError, match="has no pyproject.toml"):
        add_worktree(repository, resolve(repository, "HEAD~2"), tmp_path / "tree")
    assert not (tmp_path / "tree").exists()


def test_the_commit_s_requirements_and_what_this_environment_lacks(repository):
    assert requirements(repository) == ["numpy>=1.0", "scipy>=1.0"]
    assert unmet(["numpy>=1.0", "scipy>=1.0"]) == []
    assert unmet(["numpy<1", "no-such-package-here>=1", 'numpy<1; python_version < "3"']) == [
        "numpy<1",
        "no-such-package-here>=1",
    ]


def test_the_commit_s_plugins_are_the_ones_found(repository, tmp_path):
    version = prepare(repository, "HEAD", resolve(repository, "HEAD"), tmp_path)
    assert version.environment == "this" and version.python == sys.executable
    listed = subprocess.run(
        [sys.executable, "-c", "import importlib.metadata as m, mine; "
         "print(sorted(e.value for e in m.entry_points(group='harness.solvers')), mine.VALUE)"],
        env={**os.environ, "PYTHONPATH": os.pathsep.join(version.path)}, capture_output=True, text=True,
        check=True, cwd=tmp_path,  # as a probe runs: the checkout's own metadata is not in the way
    ).stdout.split()  # fmt: skip
    assert listed == ["['mine:Solver']", "2"]  # its plugins, its code
    assert write_metadata(repository, tmp_path / "meta") == tmp_path / "meta"
