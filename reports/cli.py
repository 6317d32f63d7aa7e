"""``harness report`` and ``harness compare``: click commands for the ``harness.commands`` entry points.

``harness --help`` imports this module to list the commands, so it imports only click at the top: the
commands import pandas, matplotlib and rich (through the reports modules) when they run.
"""

from __future__ import annotations

from pathlib import Path

import click

from reports._layout import REPORT_DIR


class InputError(click.ClickException):
    """Unusable input: exit code 2, so that CI tells it apart from a regression (exit code 1)."""

    exit_code = 2


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
def report(out: Path, expressions: int) -> None:
    from reports._report import build_report

    try:
        page, text = build_report(out, expressions=expressions)
    except FileNotFoundError as error:
        raise InputError(f"{error}. Run `harness run --out {out}` first.") from None
    click.echo(f"report: {page}")
    click.echo(f"markdown: {text}")


@click.command(
    "compare",
    help="Compare two runs (record directories) or two pytest-benchmark JSON files, OLD then NEW. "
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
    help="A time is slower when NEW/OLD exceeds 1 + threshold.",
)
@click.option(
    "--tolerance",
    type=click.FloatRange(min=0),
    default=1e-9,
    show_default=True,
    help="Relative change above which a quality figure (objective, coverage, RMS) counts as changed.",
)
@click.option(
    "--min-time",
    type=click.FloatRange(min=0),
    default=0.01,
    show_default=True,
    help="Seconds below which a time is timer noise: never judged slower or faster.",
)
@click.option(
    "--fail-on-time/--warn-on-time",
    default=False,
    show_default=True,
    help="Fail on slower times too; by default they are printed as warnings (shared machines are noisy).",
)
@click.option("--only-changes", is_flag=True, help="Leave unchanged metrics out of the table.")
def compare(
    old: Path,
    new: Path,
    threshold: float,
    tolerance: float,
    min_time: float,
    fail_on_time: bool,
    only_changes: bool,
) -> None:
    from rich.console import Console

    from reports._compare import compare as compare_runs
    from reports._compare import comparison_table

    try:
        comparison = compare_runs(old, new, threshold=threshold, tolerance=tolerance, min_time=min_time)
    except (FileNotFoundError, ValueError) as error:
        raise InputError(str(error)) from None
    console = Console(width=160)
    console.print(comparison_table(comparison, fail_on_time=fail_on_time, only_changes=only_changes))
    regressions = comparison.regressions(fail_on_time=fail_on_time)
    warnings = comparison.warnings(fail_on_time=fail_on_time)
    compared = sum(change.verdict != "added" for change in comparison.changes)
    summary = f"{compared} metrics compared: {len(regressions)} regressions, {len(warnings)} timing warnings"
    if regressions:
        console.print(f"[bold red]FAIL[/] {summary}")
        click.get_current_context().exit(1)
    console.print(f"[green]OK[/] {summary}")
