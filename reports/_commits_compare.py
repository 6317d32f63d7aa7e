"""``harness compare --commits BASE HEAD``: two commits measured alternately in one job, then judged.

Each commit is checked out into a worktree of its own (`harness._commits`), both are measured on the same
instances and the same machine, interleaved sample by sample within a time budget
(`harness._bench_session`), and every case is judged against itself (`reports._ab`). No time recorded on
another machine, or at another moment, enters the verdict.
"""

from __future__ import annotations

import shutil
import tempfile
from dataclasses import dataclass, replace
from pathlib import Path

from rich.console import Console
from rich.markup import escape

from harness import Suite
from registry import HarnessError
from reports._ab import ABComparison, compare_measurement, comparison_table
from reports._gate import ACCEPTED_FILE, accepted_for, read_accepted


@dataclass(frozen=True)
class GateResult:
    """What the gate decided: the comparison, the slow-downs that fail, those accepted (with the entry's
    reason) and those only warned about."""

    comparison: ABComparison
    failing: list[str]
    accepted: list[str]
    warned: list[str]

    @property
    def failed(self) -> bool:
        """Whether the comparison fails: a slow-down beyond the limit not accepted, or any problem (an
        answer the check rejected, exact solvers that disagree, a case that could not be measured)."""
        return bool(self.failing or self.comparison.problems)


def run(
    repository: Path,
    base: str,
    head: str,
    suite: Suite,
    *,
    rounds: int,
    repeat: int,
    sample_time: float,
    budget: float | None,
    alpha: float,
    threshold: float,
    fail_above: float | None,
    warn_above: float,
    console: Console,
) -> GateResult:
    """Measure ``base`` and ``head`` of ``repository`` alternately and judge every case (module notes).

    Raises
    ------
    HarnessError
        When a ref names no commit, a commit cannot be checked out or its environment made, or the
        accepted slow-downs file of ``head`` is malformed.
    """
    from harness import commit_range, measure, prepare, remove_worktree, resolve

    commits = [resolve(repository, base), resolve(repository, head)]
    scratch = Path(tempfile.mkdtemp(prefix="harness-commits-"))
    versions = []
    try:
        for ref, commit in zip((base, head), commits, strict=True):
            folder = scratch / f"side-{len(versions)}"
            folder.mkdir()
            versions.append(prepare(repository, ref, commit, folder))
        if versions[0].name == versions[1].name:  # the same ref twice (an A/A comparison), told apart
            versions[1] = replace(versions[1], name=f"{head} (again)")
        entries = read_accepted(Path(versions[1].path[0]) / ACCEPTED_FILE)
        for version in versions:
            where = "this environment" if version.environment == "this" else version.environment
            console.print(f"[dim]{escape(version.name)}: {version.short}, run by {escape(where)}[/]")
        with console.status("measuring") as status:
            measurement = measure(
                versions,
                suite,
                scratch=scratch,
                rounds=rounds,
                repeat=repeat,
                min_time=sample_time,
                budget=budget,
                progress=lambda what, done, total: status.update(f"{what}: job {done} of {total}"),
            )
    finally:
        for version in versions:
            remove_worktree(repository, Path(version.path[0]))
        shutil.rmtree(scratch, ignore_errors=True)
    comparison = compare_measurement(measurement, alpha=alpha, threshold=threshold)
    in_range = commit_range(repository, f"{commits[0]}..{commits[1]}")[1:] if commits[0] != commits[1] else []
    failing, accepted, warned = [], [], []
    for case in comparison.slower(min(warn_above, fail_above or warn_above)):
        line = f"{case.case} x{case.test.ratio:.3f} [{case.test.low:.3f}, {case.test.high:.3f}]"
        entry = accepted_for(case.case, case.test.ratio, commits[0], in_range, entries)
        if entry is not None:
            accepted.append(f"{line}: accepted, {entry.reason}")
        elif fail_above is not None and case.test.ratio > fail_above:
            failing.append(line)
        elif case.test.ratio > warn_above:
            warned.append(line)
    console.print(comparison_table(comparison, fail_above=fail_above, warn_above=warn_above))
    return GateResult(comparison, failing, accepted, warned)


def report(result: GateResult, console: Console) -> None:
    """Print what the gate decided, one line each, and the summary line (FAIL or OK)."""
    for line in result.comparison.problems:
        console.print(f"[bold red]problem:[/] {escape(line)}")
    for line in result.accepted:
        console.print(f"[cyan]accepted slow-down:[/] {escape(line)}")
    for line in result.warned:
        console.print(f"[yellow]slower:[/] {escape(line)}")
    for line in result.failing:
        console.print(f"[bold red]slower beyond the limit:[/] {escape(line)}")
    counts: dict[str, int] = {}
    for case in result.comparison.cases:
        counts[case.test.verdict] = counts.get(case.test.verdict, 0) + 1
    summary = ", ".join(f"{count} {verdict}" for verdict, count in sorted(counts.items()))
    if result.failed:
        console.print(
            f"[bold red]FAIL[/] {len(result.comparison.cases)} cases ({summary}): {len(result.failing)} "
            f"slow-downs beyond the limit, {len(result.comparison.problems)} problems"
        )
    else:
        console.print(f"[green]OK[/] {len(result.comparison.cases)} cases ({summary})")


def check_suite_solvers(suite: Suite, solvers: str | None) -> Suite:
    """``suite`` with only the solvers ``solvers`` lists (a comma list of labels), when given.

    Raises
    ------
    HarnessError
        For an empty list, a solver this environment does not have, or a setting its plugin refuses (before
        any commit is measured).
    """
    if solvers is None:
        return suite
    from harness import check_settings, expand_names, solver_names, split_requests

    try:
        chosen = tuple(split_requests(solvers))
    except HarnessError as error:
        raise HarnessError(f"--solvers {error}") from None
    if not chosen:
        raise HarnessError("--solvers: give at least one solver label")
    chosen = expand_names(chosen, solver_names(), "solver", "--solvers")
    check_settings(chosen, [])
    return replace(suite, solvers=chosen)
