"""``harness report`` and ``harness compare``: click commands for the ``harness.commands`` entry points.

``harness --help`` imports this module to list the commands, so it imports only click at the top: the
commands import pandas, matplotlib and rich (through the reports modules) when they run.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import click

from reports._layout import HISTORY_FILE, REPORT_DIR

if TYPE_CHECKING:
    import pandas as pd
    from rich.console import Console


class InputError(click.ClickException):
    """Unusable input: exit code 2, so that CI tells it apart from a regression (exit code 1)."""

    exit_code = 2


@click.command("show")
@click.argument("out", type=click.Path(file_okay=False, path_type=Path))
def show(out: Path) -> None:
    """Summary tables of the run in OUT: cells by status, sequences per solver, transfer errors (and their
    ratio to deformation transfer), the paper's claims held or not, problems."""
    from reports._terminal import print_summary

    print_summary(out)


@click.command(
    "report",
    help=f"Write the report of the run in OUT to OUT/{REPORT_DIR}/index.html (self-contained) and report.md.",
)
@click.argument("out", type=click.Path(file_okay=False, path_type=Path))
@click.option(
    "--expressions",
    type=click.IntRange(min=1),
    default=5,
    show_default=True,
    help="Leading expressions drawn per solver on the contact sheets.",
)
@click.option(
    "--history",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    default=None,
    show_default=f"{HISTORY_FILE} beside OUT, when there is one",
    help="History file of CI runs (harness compare --history FILE --append) to plot in the report.",
)
def report(out: Path, expressions: int, history: Path | None) -> None:
    from reports._report import build_report

    beside = out.parent / HISTORY_FILE
    if history is None and beside.is_file():
        history = beside
    try:
        page, text = build_report(out, expressions=expressions, history=history)
    except FileNotFoundError as error:
        raise InputError(f"{error}. Run `harness run --out {out}` first.") from None
    except ValueError as error:  # a history file that is not one
        raise InputError(str(error)) from None
    click.echo(f"report: {page}")
    click.echo(f"markdown: {text}")


@click.command(
    "compare",
    help="Compare two runs (record directories) or two pytest-benchmark JSON files, OLD then NEW. "
    "With --history, a time of NEW with too few repetitions to test (as a ratio to the median exact solver "
    "in the same run) is judged against its commit-to-commit spread in earlier commits, and --append "
    "records NEW there. "
    "Exit code 1 when a quality figure changed (or, with --fail-on-time, a time regressed), 2 on unusable "
    "input, else 0.",
)
@click.argument("old", type=click.Path(exists=True, path_type=Path))
@click.argument("new", type=click.Path(exists=True, path_type=Path))
@click.option(
    "--threshold",
    type=click.FloatRange(min=0),
    default=0.25,
    show_default=True,
    help="A time is slower when NEW/OLD exceeds 1 + threshold; with a history, the least margin above a "
    "figure's median, relative to it.",
)
@click.option(
    "--tolerance",
    type=click.FloatRange(min=0),
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
    type=click.FloatRange(min=0),
    default=0.01,
    show_default=True,
    help="Seconds below which a time is timer noise: never judged slower or faster.",
)
@click.option(
    "--alpha",
    type=click.FloatRange(min=0, max=1, min_open=True, max_open=True),
    default=0.01,
    show_default=True,
    help="Significance level of the test of a case's times (Welch's t-test over the repetitions of both "
    "runs, on log ratios to the median exact solver, Benjamini-Hochberg adjusted over all cases of the "
    "comparison); a time needs q < ALPHA and a change beyond --threshold to be slower or faster.",
)
@click.option(
    "--fail-on-time/--warn-on-time",
    default=False,
    show_default=True,
    help="Fail on slower times too; by default they are printed as warnings (shared machines are noisy).",
)
@click.option("--only-changes", is_flag=True, help="Leave unchanged metrics out of the table.")
@click.option(
    "--history",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    show_default="none",
    help="History file of earlier runs' ratios (e.g. benchmarks/history.csv): a time of NEW with too few "
    "repetitions to test is slower when above its figure's median + max(SPREAD x 1.4826 MAD, THRESHOLD x "
    "median) over the last WINDOW commits, each commit one value (the median of its runs; runs from a dirty "
    "tree are left out).",
)
@click.option(
    "--append",
    is_flag=True,
    help="After a comparison without regressions, append NEW's ratios to the --history file (created when "
    "missing; a run already there is not added again).",
)
@click.option(
    "--window",
    type=click.IntRange(min=1),
    default=10,
    show_default=True,
    help="Latest commits of a figure in the history that give its spread.",
)
@click.option(
    "--spread",
    type=click.FloatRange(min=0),
    default=3.0,
    show_default=True,
    help="Robust standard deviations (1.4826 MAD) a ratio may move from its history's median.",
)
@click.option(
    "--min-runs",
    type=click.IntRange(min=1),
    default=5,
    show_default=True,
    help="Fewest commits of a figure in the history to judge it by its spread (several runs of one commit "
    "count once); with fewer, a time with too few repetitions to test is left untested.",
)
def compare(
    old: Path,
    new: Path,
    threshold: float,
    tolerance: float,
    min_time: float,
    alpha: float,
    fail_on_time: bool,
    only_changes: bool,
    history: Path | None,
    append: bool,
    window: int,
    spread: float,
    min_runs: int,
    fresh_baseline: bool,
) -> None:
    from rich.console import Console
    from rich.markup import escape

    from reports._compare import changed_inputs, comparison_table, run_figures
    from reports._compare import compare as compare_runs

    if append and history is None:
        raise click.UsageError("--append needs --history FILE.")
    if history is not None and not append and not history.exists():
        raise InputError(f"{history}: no such history file (--append creates it)")
    try:
        figures = run_figures(new) if append else None
        comparison = compare_runs(
            old,
            new,
            threshold=threshold,
            tolerance=tolerance,
            min_time=min_time,
            alpha=alpha,
            history=history if history is not None and history.exists() else None,
            window=window,
            spread=spread,
            min_runs=min_runs,
        )
    except (FileNotFoundError, ValueError) as error:
        raise InputError(str(error)) from None
    console = Console(width=160)
    console.print(comparison_table(comparison, fail_on_time=fail_on_time, only_changes=only_changes))
    for line in changed_inputs(old, new):
        console.print(f"[yellow]inputs differ:[/] {escape(line)}")
    stale = _baseline_stale(old, console)
    regressions = comparison.regressions(fail_on_time=fail_on_time)
    if figures is not None and not regressions:  # a run that fails its comparison is not history
        _append(history, figures, new)
    warnings = comparison.warnings(fail_on_time=fail_on_time)
    compared = sum(change.verdict != "added" for change in comparison.changes)
    judged = sum(change.spread is not None for change in comparison.changes)
    summary = f"{compared} metrics compared: {len(regressions)} regressions, {len(warnings)} timing warnings"
    summary += f" ({judged} times judged by the history)" if comparison.history else ""
    if regressions or (stale and fresh_baseline):
        console.print(f"[bold red]FAIL[/] {summary}" + ("; the baseline is stale" if stale else ""))
        click.get_current_context().exit(1)
    console.print(f"[green]OK[/] {summary}")


def _baseline_stale(old: Path, console: Console) -> bool:
    """Print where the run ``old`` was made (nothing for a benchmark file); whether it is stale."""
    from reports._provenance import provenance

    if not old.is_dir():
        return False
    found = provenance(old)
    console.print(found.describe(), style="yellow" if found.stale else "dim", highlight=False)
    return found.stale


def _append(history: Path, figures: pd.DataFrame, new: Path) -> None:
    """Append a run's figures to the history file and say what was done."""
    from reports._history import append_history

    try:
        appended = append_history(history, figures)
    except (OSError, ValueError) as error:
        raise InputError(str(error)) from None
    if appended:
        click.echo(f"history: appended {appended} figures of {new} to {history}")
    else:
        click.echo(f"history: {new} is already in {history}")
