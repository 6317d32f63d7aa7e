"""What ``run.json`` records of the checkout: commit, dirtiness (the run's own folder left out)."""

from __future__ import annotations

import subprocess

import pytest

from harness._environment import commits_since, git_state


@pytest.fixture
def checkout(tmp_path):
    def git(*args: str) -> str:
        done = subprocess.run(["git", *args], cwd=tmp_path, capture_output=True, text=True, check=True)
        return done.stdout.strip()

    git("init", "-q")
    git("config", "user.email", "t@example.org")
    git("config", "user.name", "t")
    (tmp_path / "baseline").mkdir()
    (tmp_path / "baseline" / "run.json").write_text("{}")
    (tmp_path / "code.py").write_text("")
    git("add", "-A")
    git("commit", "-qm", "one")
    return tmp_path, git


def test_a_runs_own_folder_does_not_make_the_tree_dirty(checkout) -> None:
    root, _git = checkout
    assert git_state(root, output=root / "baseline")["dirty"] is False
    (root / "baseline" / "run.json").write_text('{"state": "running"}')
    assert git_state(root)["dirty"] is True
    assert git_state(root, output=root / "baseline")["dirty"] is False
    (root / "code.py").write_text("changed = True\n")
    assert git_state(root, output=root / "baseline")["dirty"] is True


def test_commits_since_counts_only_ancestors_of_head(checkout) -> None:
    root, git = checkout
    first = git("rev-parse", "HEAD")
    (root / "code.py").write_text("two = 2\n")
    git("commit", "-qam", "two")
    assert commits_since(first, root) == 1
    assert commits_since(git("rev-parse", "HEAD"), root) == 0
    git("checkout", "-q", "-b", "other", first)
    (root / "code.py").write_text("three = 3\n")
    git("commit", "-qam", "three")
    side = git("rev-parse", "HEAD")
    git("checkout", "-q", "-")
    assert commits_since(side, root) is None
    assert commits_since("0" * 40, root) is None
