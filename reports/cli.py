"""``harness report`` and ``harness compare``: click commands for the ``harness.commands`` entry points.

``harness --help`` imports this module to list the commands, so it imports only click at the top: the
commands import pandas, matplotlib and rich (through the reports modules) when they run.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import click

from harness import DURATION, FiniteFloatRange
from harness.cli import UserError
from reports._layout import REPORT_DIR

if TYPE_CHECKING:
    from rich.console import Console


def measuring_options(prefix: str = ""):
    """The options of a timing session (`harness.measure`): the suite, its solvers, rounds, samples and
    their least CPU time; ``prefix`` begins each help text (``With --commits: ``)."""

    def say(text: str) -> str:
        return prefix + text if prefix else text[0].upper() + text[1:]

    def add(command):
        options = [
            click.option(
                "--suite",
                default="quick",
                show_default=True,
                help=say(
                    "the timing suite: quick (tiny and arkit52, every solver), large (film's first "
                    "expressions), transfer (female: ebfr and dt), ci (what the CI gate times)."
                ),
            ),
            click.option("--solvers", default=None, help=say("only these solver labels (comma list).")),
            click.option(
                "--rounds",
                type=click.IntRange(min=2, max=100),
                default=3,
                show_default=True,
                help=say("rounds of fresh processes, at most."),
            ),
            click.option(
                "--repeat",
                type=click.IntRange(min=1, max=100),
                default=3,
                show_default=True,
                help=say("samples per job, commit and round (two commits' taken alternately)."),
            ),
            click.option(
                "--sample-time",
                type=DURATION,
                default="10ms",
                show_default=True,
                help=say("least CPU time of one sample; a faster solve is repeated within it."),
            ),
        ]
        for option in reversed(options):
            command = option(command)
        return command

    return add


class InputError(UserError):
    """Unusable input: exit code 2, so that CI tells it apart from a regression (exit code 1), printed as
    every command prints bad input (``error: ...``)."""


@click.command("show")
@click.argument("out", type=click.Path(file_okay=False, path_type=Path))
def show(out: Path) -> None:
    """Summary tables of the run in OUT: cells by status, sequences per solver, transfer errors (and their
    ratio to deformation transfer), the paper's claims held or not, problems."""
    from reports._terminal import print_summary

    print_summary(out)


@click.command(
    "report",
    help=f"Write the report of the run in OUT to OUT/{REPORT_DIR}/index.html (self-contained) and report.md. "
    "An earlier report there is replaced with --force only; a folder holding anything else is refused.",
)
@click.argument("out", type=click.Path(file_okay=False, path_type=Path))
@click.option(
    "--expressions",
    type=click.IntRange(min=1),
    default=5,
    show_default=True,
    help="Leading expressions drawn per solver on the contact sheets.",
)
@click.option("--force", is_flag=True, help=f"Replace an earlier report in OUT/{REPORT_DIR}.")
def report(out: Path, expressions: int, force: bool) -> None:
    from reports._report import build_report
    from session import EXPRESSIONS_FILE, SHEET_FILE

    try:
        page, text = build_report(out, expressions=expressions, force=force)
    except FileNotFoundError as error:
        if (out / EXPRESSIONS_FILE).is_file() or (out / SHEET_FILE).is_file():
            raise InputError(
                f"{out}: is a session folder of `harness pack` ({EXPRESSIONS_FILE}, {SHEET_FILE}), not a run "
                "folder; `harness report` reports a run folder that `harness run` wrote"
            ) from None
        raise InputError(f"{error}. Run `harness run --out {out}` first.") from None
    click.echo(f"report: {page}")
    click.echo(f"markdown: {text}")


@click.command(
    "compare",
    help="Compare two runs (record directories) or two pytest-benchmark JSON files, OLD then NEW; or, with "
    "--commits BASE HEAD, measure two commits of the repository alternately on the same instances and judge "
    "each case's CPU time against itself (A/B in one job, as asv continuous). "
    "Exit code 1 when a quality figure changed, an answer failed the independent check, or (with "
    "--fail-above) a case is confirmed slower beyond the limit; 2 on unusable input; else 0.",
)
@click.argument("old", type=click.Path(exists=True, path_type=Path), required=False)
@click.argument("new", type=click.Path(exists=True, path_type=Path), required=False)
@click.option(
    "--commits",
    nargs=2,
    metavar="BASE HEAD",
    default=None,
    help="Measure these two commits (any git refs) of the repository holding the current folder, each from "
    "a worktree of its own, instead of comparing two folders.",
)
@measuring_options("With --commits: ")
@click.option(
    "--budget",
    type=DURATION,
    default="5m",
    show_default=True,
    help="With --commits: no round starts that would end past this time.",
)
@click.option(
    "--fail-above",
    type=FiniteFloatRange(min=1, min_open=True),
    default=None,
    show_default="never",
    help="With --commits: fail when a case is confirmed slower by more than this ratio (not accepted in "
    "benchmarks/accepted-slowdowns.toml of HEAD).",
)
@click.option(
    "--warn-above",
    type=FiniteFloatRange(min=1),
    default=1.25,
    show_default=True,
    help="With --commits: print a warning for a case confirmed slower by more than this ratio.",
)
@click.option(
    "--threshold",
    type=FiniteFloatRange(min=0),
    default=0.1,
    show_default=True,
    help="A time is slower when NEW/OLD exceeds 1 + threshold and the paired test says so, the same when its "
    "interval lies within it.",
)
@click.option(
    "--tolerance",
    type=FiniteFloatRange(min=0),
    default=1e-7,
    show_default=True,
    help="Relative change above which a quality figure (objective, coverage, RMS) counts as changed "
    "(benchmarks/README.md derives the default from the numerics).",
)
@click.option(
    "--fresh-baseline",
    is_flag=True,
    help="Fail (exit 1) when OLD is a run made from a dirty tree or at a commit outside HEAD's history.",
)
@click.option(
    "--min-time",
    type=FiniteFloatRange(min=0),
    default=0.01,
    show_default=True,
    help="Of two runs: seconds below which a case's median sequence is timer noise, left untested.",
)
@click.option(
    "--alpha",
    type=FiniteFloatRange(min=0, max=1, min_open=True, max_open=True),
    default=0.01,
    show_default=True,
    help="Level of the paired test of each case's times (Benjamini-Hochberg adjusted over all cases of the "
    "comparison) and of their intervals.",
)
@click.option(
    "--fail-on-time/--warn-on-time",
    default=False,
    show_default=True,
    help="Of two runs: fail on slower times too; by default they are printed as warnings.",
)
@click.option("--only-changes", is_flag=True, help="Leave unchanged and untested metrics out of the table.")
def compare(
    old: Path | None,
    new: Path | None,
    commits: tuple[str, str] | None,
    suite: str,
    solvers: str | None,
    rounds: int,
    repeat: int,
    sample_time: float,
    budget: float,
    fail_above: float | None,
    warn_above: float,
    threshold: float,
    tolerance: float,
    min_time: float,
    alpha: float,
    fail_on_time: bool,
    only_changes: bool,
    fresh_baseline: bool,
) -> None:
    from rich.console import Console
    from rich.markup import escape

    from reports._compare import changed_inputs, compare as compare_runs, comparison_table

    if commits is not None:
        if old is not None or new is not None:
            raise click.UsageError("give either OLD NEW or --commits BASE HEAD, not both.")
        _compare_commits(
            commits, suite=suite, solvers=solvers, rounds=rounds, repeat=repeat, sample_time=sample_time,
            budget=budget, alpha=alpha, threshold=threshold, fail_above=fail_above, warn_above=warn_above,
        )  # fmt: skip
        return
    if old is None or new is None:
        raise click.UsageError("give OLD and NEW (two runs or two benchmark files), or --commits BASE HEAD.")
    try:
        comparison = compare_runs(
            old, new, threshold=threshold, tolerance=tolerance, min_time=min_time, alpha=alpha
        )
    except (FileNotFoundError, ValueError) as error:
        raise InputError(str(error)) from None
    console = Console(width=160)
    console.print(comparison_table(comparison, fail_on_time=fail_on_time, only_changes=only_changes))
    for line in changed_inputs(old, new):
        console.print(f"[yellow]inputs differ:[/] {escape(line)}")
    stale = _baseline_stale(old, console)
    regressions = comparison.regressions(fail_on_time=fail_on_time)
    warnings = comparison.warnings(fail_on_time=fail_on_time)
    compared = sum(change.verdict != "added" for change in comparison.changes)
    summary = f"{compared} metrics compared: {len(regressions)} regressions, {len(warnings)} timing warnings"
    if regressions or (stale and fresh_baseline):
        console.print(f"[bold red]FAIL[/] {summary}" + ("; the baseline is stale" if stale else ""))
        click.get_current_context().exit(1)
    console.print(f"[green]OK[/] {summary}")


def _compare_commits(commits: tuple[str, str], *, suite: str, solvers: str | None, **settings) -> None:
    """``compare --commits``: measure, judge, print, and exit 1 when the gate fails."""
    from rich.console import Console

    import harness
    from registry import HarnessError
    from reports._commits_compare import check_suite_solvers, report, run

    console = Console(width=180)
    try:
        chosen = check_suite_solvers(harness.suite(suite), solvers)
        repository = harness.repository_of(Path.cwd())
        result = run(repository, *commits, chosen, console=console, **settings)
    except HarnessError as error:
        raise InputError(str(error)) from None
    report(result, console)
    if result.failed:
        click.get_current_context().exit(1)


def _baseline_stale(old: Path, console: Console) -> bool:
    """Print where the run ``old`` was made (nothing for a benchmark file); whether it is stale."""
    from reports._provenance import provenance

    if not old.is_dir():
        return False
    found = provenance(old)
    console.print(found.describe(), style="yellow" if found.stale else "dim", highlight=False)
    return found.stale
