"""Where a baseline run came from, and whether it still stands for the code being checked.

A baseline is a run whose quality figures later runs must reproduce (`reports.compare`). It stands for the
code at one commit only when it was made from a clean tree (no uncommitted change shaped its figures) at a
commit in HEAD's history; every commit since may have changed what the figures should be. The run's
``run.json`` records both (``git.commit``, ``git.dirty``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import harness

#: The one command that remakes the committed CI baseline (see benchmarks/README.md).
REGENERATE = "harness run --preset quick --solvers all --out benchmarks/baseline --force --quiet"


@dataclass(frozen=True)
class Provenance:
    """A baseline run's commit, whether its tree was clean, and how far HEAD has moved since.

    ``behind`` is the number of commits from the baseline's commit to HEAD (0: made at HEAD), None when
    the commit is not in HEAD's history or unknown.
    """

    commit: str | None
    dirty: bool | None
    behind: int | None

    @property
    def stale(self) -> bool:
        """Whether the baseline cannot stand for HEAD: an unknown commit, one outside HEAD's history, or a
        tree with uncommitted changes."""
        return self.commit is None or self.dirty is not False or self.behind is None

    def describe(self) -> str:
        """One line: where the baseline was made and, when stale, why and how to remake it."""
        where = f"made at {self.commit[:12]}" if self.commit else "made at an unknown commit"
        where += " from a dirty tree" if self.dirty else ""
        if self.behind is not None:
            where += f", {self.behind} commit{'s' * (self.behind != 1)} before HEAD"
        elif self.commit:
            where += ", a commit outside HEAD's history"
        if not self.stale:
            return f"baseline {where}"
        return f"baseline is stale: {where}; remake it with `{REGENERATE}` on a clean checkout and commit it"


def provenance(run: str | Path) -> Provenance:
    """The `Provenance` of a run directory, read from its ``run.json`` and the harness's git checkout.

    Raises
    ------
    FileNotFoundError
        When ``run`` holds no ``run.json``.
    """
    git = harness.read_run(run).get("git") or {}
    commit = git.get("commit") if isinstance(git.get("commit"), str) else None
    dirty = git.get("dirty") if isinstance(git.get("dirty"), bool) else None
    return Provenance(commit, dirty, harness.commits_since(commit) if commit else None)
