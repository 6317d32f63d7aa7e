"""What ``harness track`` does with a repository, a store and a suite: measure commits, find steps, bisect.

A history has one *anchor* commit per machine and suite: the one its first run was given (``--anchor``),
or the first commit of its range, and every later run of that store keeps it. A commit is measured once
per machine, suite and anchor unless asked again: its worktree and the anchor's (`harness._commits`) are
measured side by side, sample by sample, in rounds of fresh processes (`harness.measure`), and both sides'
samples are added to the store (`harness.TrackStore`), so that its figure is a ratio to the anchor taken
in the same moments (`reports._steps`). Steps come from the store's samples of this machine. Bisecting
measures, for every step whose first commit is not yet named, the middle one of the unmeasured commits
between the step's two measured ends, until every step is named or nothing is left to measure.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import pandas as pd
from rich.console import Console
from rich.markup import escape

from harness import CommitFacts, Suite, TrackStore
from reports._steps import ANCHOR, COMMIT, Step, commit_series, detect_steps


class Tracker:
    """Measuring commits of ``repository`` into ``store`` on ``suite`` (module notes).

    Parameters
    ----------
    machine : str, optional
        The store's machine id whose samples are read; this machine by default (and always the one whose
        measurements are added).
    anchor : str, optional
        The anchor commit: by default the one the store's samples of this machine and suite have (the
        first commit measured, when it has none yet: `adopt`).

    Raises
    ------
    harness.StoreError
        When the store holds several anchors for this machine and suite and none is chosen.
    """

    def __init__(
        self,
        repository: Path,
        store: TrackStore,
        suite: Suite,
        *,
        rounds: int = 3,
        repeat: int = 3,
        sample_time: float = 0.01,
        machine: str | None = None,
        anchor: str | None = None,
        console: Console | None = None,
    ) -> None:
        import harness

        self.repository, self.store, self.suite = repository, store, suite
        self.rounds, self.repeat, self.sample_time = rounds, repeat, sample_time
        self.machine = harness.machine()
        self.machine_id = machine or harness.machine_id(self.machine)
        self.console = console or Console(quiet=True)
        self.names: dict[str, str] = {}
        self.failed: set[str] = set()  # commits this tracker could not measure (none of their samples)
        self._samples: pd.DataFrame | None = None
        self.anchor = anchor or self._stored_anchor()

    def _stored_anchor(self) -> str | None:
        from harness import StoreError

        found = set(self.store.read(machine=self.machine_id, suite=self.suite.name)["anchor"])
        if len(found) > 1:
            listed = ", ".join(sorted(anchor[:10] for anchor in found))
            raise StoreError(
                f"{self.store.url}: suite {self.suite.name} has several anchors on this machine ({listed}); "
                "choose one with --anchor"
            )
        return next(iter(found), None)

    def adopt(self, commit: str) -> None:
        """Take ``commit`` as the anchor when there is none yet."""
        if self.anchor is None:
            self.anchor, self._samples = commit, None

    def order(self, spec: str) -> list[str]:
        """The commits of ``spec`` oldest first: ``A..B``, or a tip and all its first parents."""
        from harness import commit_range, first_parents

        if ".." in spec:
            return commit_range(self.repository, spec)
        return first_parents(self.repository, spec)

    def samples(self) -> pd.DataFrame:
        """The store's samples of this machine and suite (read once, again after a measurement)."""
        if self._samples is None:
            self._samples = self.store.read(
                machine=self.machine_id, suite=self.suite.name, anchor=self.anchor
            )
        return self._samples

    def measured(self) -> set[str]:
        """Commits the store holds for this machine and suite."""
        return set(self.samples()["commit"])

    def measure(self, commit: str, *, again: bool = False) -> bool:
        """Measure ``commit`` into the store; False when it is there and not ``again`` (nothing done), or
        when nothing of it could be measured (the reasons printed; it joins `failed`).

        Raises
        ------
        harness.CommitError
            When the commit cannot be checked out or run.
        """
        from harness import measure, prepare, remove_worktree

        self.adopt(commit)
        facts = self._facts(commit)
        if commit in self.measured() and not again:
            self.console.print(f"[dim]{escape(self.names[commit])}: in the store[/]")
            return False
        scratch = Path(tempfile.mkdtemp(prefix="harness-track-"))
        versions = []
        try:
            for name, which in ((ANCHOR, self.anchor), (COMMIT, commit)):
                folder = scratch / name
                folder.mkdir()
                versions.append(prepare(self.repository, name, which, folder))
            with self.console.status(f"measuring {self.names[commit]}") as status:
                found = measure(
                    versions,
                    self.suite,
                    scratch=scratch,
                    rounds=self.rounds,
                    repeat=self.repeat,
                    min_time=self.sample_time,
                    progress=lambda what, done, total: status.update(
                        f"{self.names[commit]}: {what}, job {done} of {total}"
                    ),
                )
        finally:
            for version in versions:
                remove_worktree(self.repository, Path(version.path[0]))
            shutil.rmtree(scratch, ignore_errors=True)
        if found.samples.empty:
            self.failed.add(commit)
            reasons = "; ".join(dict.fromkeys(found.errors)) or "no sample"
            self.console.print(f"[red]{escape(self.names[commit])}: nothing measured[/]: {escape(reasons)}")
            return False
        self.store.add(found, facts, self.anchor, self.machine)
        self._samples = None
        problems = len(found.errors) + int((found.answers.get("problem", pd.Series()) != "").sum())
        note = f", [red]{problems} problems[/]" if problems else ""
        self.console.print(
            f"{escape(self.names[commit])}: {len(found.samples)} samples in {found.rounds} rounds, "
            f"{found.seconds:.0f} s{note}"
        )
        return True

    def steps(self, order: list[str], *, threshold: float, alpha: float) -> list[Step]:
        """The steps of every case over the measured commits of ``order``."""
        for commit in order:
            if commit in self.measured():
                self._facts(commit)
        series = commit_series(self.samples(), order)
        neighbours = dict(zip(order[1:], order[:-1], strict=True))
        return detect_steps(series, neighbours=neighbours, threshold=threshold, alpha=alpha)

    def bisect(self, order: list[str], *, threshold: float, alpha: float) -> list[Step]:
        """Measure inside each unnamed step until every step is named or nothing is left to measure; the
        steps found last."""
        position = {commit: index for index, commit in enumerate(order)}
        while True:
            found = self.steps(order, threshold=threshold, alpha=alpha)
            measured = self.measured()
            chosen = set()
            for step in found:
                if step.exact:
                    continue
                between = [
                    commit
                    for commit in order[position[step.previous] + 1 : position[step.commit]]
                    if commit not in measured and commit not in self.failed
                ]
                if between:
                    chosen.add(between[len(between) // 2])
            if not chosen:
                return found
            for commit in sorted(chosen, key=position.__getitem__):
                self.measure(commit)

    def series(self, order: list[str]) -> pd.DataFrame:
        """Each case's figure per measured commit of ``order`` (`reports._steps.commit_series`)."""
        return commit_series(self.samples(), order)

    def names_of(self, commit: str) -> str:
        """``abc1234567 subject`` of a commit."""
        self._facts(commit)
        return self.names[commit]

    def _facts(self, commit: str) -> CommitFacts:
        """The commit's date and subject (and its display name in `names`)."""
        from harness import commit_facts

        facts = commit_facts(self.repository, commit)
        self.names[commit] = f"{commit[:10]} {facts.subject[:60]}"
        return facts
