"""The timing gate of ``harness compare --commits``: which slow-downs fail, and which were accepted.

A confirmed slow-down (a case judged *slower*, `reports._paired`) beyond ``fail_above`` fails the
comparison; one beyond ``warn_above`` is printed as a warning. An intended slow-down (a more accurate
method, a check that costs time) is accepted by an entry in a committed TOML file, never by switching the
gate off::

    [[slowdown]]
    after = "351111f"                  # the commit the slow-down is measured from (HEAD~1 of the commit
                                       # that brings it, which is where this entry is written)
    case = "*/cpsat"                   # the cases it covers (shell-style pattern)
    reason = "CP-SAT now proves every bound it reports"
    max_ratio = 2.0                    # optional: a larger slow-down still fails

``commit = "<id>"`` instead of ``after`` names the commit that brings the slow-down, for a comparison
whose range holds it (an entry written after the fact, or a range of several commits). An entry needs a
reason; one that matches no case is reported, so stale entries do not pile up unseen.
"""

from __future__ import annotations

import fnmatch
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

from registry import HarnessError

#: Where the accepted slow-downs live, relative to the repository.
ACCEPTED_FILE = Path("benchmarks") / "accepted-slowdowns.toml"


@dataclass(frozen=True)
class Accepted:
    """One accepted slow-down (module notes)."""

    case: str
    reason: str
    after: str = ""
    commit: str = ""
    max_ratio: float = math.inf

    def covers(self, case: str, ratio: float, base: str, commits: list[str]) -> bool:
        """Whether this entry accepts ``case`` slowed by ``ratio`` in the comparison from ``base`` over
        ``commits`` (the commits after ``base`` up to the new one)."""
        if not fnmatch.fnmatchcase(case, self.case) or ratio > self.max_ratio:
            return False
        if self.after:
            return base.startswith(self.after)
        return any(commit.startswith(self.commit) for commit in commits)


def read_accepted(path: Path) -> list[Accepted]:
    """The entries of an accepted slow-downs file (none when it does not exist).

    Raises
    ------
    HarnessError
        Naming the file and the entry, for a file that does not parse or an entry without ``case``,
        ``reason`` and exactly one of ``after`` and ``commit``, or with a ``max_ratio`` not above 1.
    """
    if not path.is_file():
        return []
    try:
        document = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as error:
        raise HarnessError(f"{path}: not a TOML file of accepted slow-downs ({error})") from None
    entries = document.get("slowdown", [])
    if not isinstance(entries, list) or set(document) - {"slowdown"}:
        raise HarnessError(f"{path}: expected only [[slowdown]] tables")
    found = []
    for number, entry in enumerate(entries, start=1):
        where = f"{path}: slowdown {number}"
        if not isinstance(entry, dict) or set(entry) - {"case", "reason", "after", "commit", "max_ratio"}:
            raise HarnessError(f"{where}: keys are case, reason, after or commit, and max_ratio")
        texts = {key: entry.get(key, "") for key in ("case", "reason", "after", "commit")}
        if not all(isinstance(value, str) for value in texts.values()):
            raise HarnessError(f"{where}: case, reason, after and commit are strings")
        if not texts["case"].strip() or not texts["reason"].strip():
            raise HarnessError(f"{where}: needs a case pattern and a reason")
        if bool(texts["after"]) == bool(texts["commit"]):
            raise HarnessError(f"{where}: give exactly one of after (the base commit) and commit")
        if any(len(texts[key]) < 7 and texts[key] for key in ("after", "commit")):
            raise HarnessError(f"{where}: a commit id needs at least 7 hex digits")
        ratio = entry.get("max_ratio", math.inf)
        if isinstance(ratio, bool) or not isinstance(ratio, int | float) or not ratio > 1.0:
            raise HarnessError(f"{where}: max_ratio must be a number above 1")
        found.append(Accepted(max_ratio=float(ratio), **texts))
    return found


def accepted_for(
    case: str, ratio: float, base: str, commits: list[str], entries: list[Accepted]
) -> Accepted | None:
    """The first entry that accepts ``case`` slowed by ``ratio`` (see `Accepted.covers`), else None."""
    return next((entry for entry in entries if entry.covers(case, ratio, base, commits)), None)
