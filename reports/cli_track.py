"""``harness track``: timings across commits, their steps, and a dashboard (asv's ``run A..B`` and
``publish``).

``harness track RANGE`` (the same as ``harness track run RANGE``) measures every commit of a range, or
every n-th, from a worktree of its own, into the results store (`harness._track_store`); ``--bisect`` then
measures the commits inside each step until the step's first commit is named. ``harness track steps``
prints the steps of what a store holds for this machine, ``harness track publish`` writes the dashboard.

Like the other commands of this package it imports only click at the top.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import click
from rich.markup import escape

from harness import FiniteFloatRange
from reports.cli import InputError, measuring_options

if TYPE_CHECKING:
    from rich.console import Console

#: The store of a repository's track runs unless ``--store`` names another (inside ``results/``, which git
#: ignores).
DEFAULT_STORE = "results/track"


class _TrackGroup(click.Group):
    """``track`` whose first word, when it is no subcommand, is the range of ``track run``."""

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        if args and args[0] not in self.commands and args[0] not in ("--help", "-h"):
            args = ["run", *args]
        return super().parse_args(ctx, args)


def _store_option(command):
    command = click.option(
        "--anchor",
        default=None,
        show_default="the store's, else the range's first commit",
        help="The commit every commit is measured beside (its figure is a ratio to the anchor's time).",
    )(command)
    return click.option(
        "--store",
        default=DEFAULT_STORE,
        show_default=True,
        help="The results store: a folder, or any fsspec URL (s3://bucket/track) shared between machines.",
    )(command)


def _tracker(store: str, suite, anchor: str | None, **settings):
    """The `reports._tracking.Tracker` of the repository holding the current folder."""
    import harness
    from reports._tracking import Tracker

    opened = harness.TrackStore(store)
    repository = harness.repository_of(Path.cwd())
    chosen = None if anchor is None else harness.resolve(repository, anchor)
    return Tracker(repository, opened, suite, anchor=chosen, **settings)


def _judging_options(command):
    command = click.option(
        "--threshold",
        type=FiniteFloatRange(min=0),
        default=0.1,
        show_default=True,
        help="Least relative size of a step.",
    )(command)
    return click.option(
        "--alpha",
        type=FiniteFloatRange(min=0, max=1, min_open=True, max_open=True),
        default=0.01,
        show_default=True,
        help="Level of Welch's test between two levels of a case, and of the steps' intervals.",
    )(command)


@click.group("track", cls=_TrackGroup)
def track() -> None:
    """Timings across commits: measure a range into a store (track RANGE), find its steps, publish a
    dashboard."""


@track.command("run")
@click.argument("commits")
@measuring_options()
@click.option(
    "--every",
    type=click.IntRange(min=1),
    default=1,
    show_default=True,
    help="Measure every n-th commit of the range (its first and last always).",
)
@click.option("--bisect", is_flag=True, help="Then measure the commits inside each step until it is named.")
@click.option("--again", is_flag=True, help="Measure commits the store already holds for this machine too.")
@_store_option
@_judging_options
def run(
    commits: str,
    suite: str,
    solvers: str | None,
    every: int,
    bisect: bool,
    again: bool,
    rounds: int,
    repeat: int,
    sample_time: float,
    anchor: str | None,
    store: str,
    threshold: float,
    alpha: float,
) -> None:
    """Measure COMMITS (A..B, first parents, or one ref) of the repository holding the current folder into
    the store, each beside the history's anchor commit, then print the steps of each case; with --bisect,
    measure inside each step until its first commit is named."""
    from rich.console import Console

    import harness
    from registry import HarnessError
    from reports._commits_compare import check_suite_solvers

    console = Console(width=180)
    try:
        chosen = check_suite_solvers(harness.suite(suite), solvers)
        tracker = _tracker(
            store, chosen, anchor, rounds=rounds, repeat=repeat, sample_time=sample_time, console=console
        )
        listed = harness.commit_range(tracker.repository, commits, strict=True)
        tracker.adopt(listed[0])
        console.print(f"[dim]anchor: {escape(tracker.names_of(tracker.anchor))}[/]")
        chosen_commits = listed[::every] + ([listed[-1]] if (len(listed) - 1) % every else [])
        for commit in chosen_commits:
            tracker.measure(commit, again=again)
        steps = tracker.steps(listed, threshold=threshold, alpha=alpha)
        if bisect:
            steps = tracker.bisect(listed, threshold=threshold, alpha=alpha)
    except HarnessError as error:
        raise InputError(str(error)) from None
    _print_steps(console, steps, tracker.names)


@track.command("steps")
@click.option("--suite", default="quick", show_default=True, help="The suite whose samples are read.")
@click.option(
    "--range",
    "commits",
    default="HEAD",
    show_default=True,
    help="Commits whose samples are read, in this order (A..B or a tip: its first parents).",
)
@click.option("--machine", default=None, show_default="this machine", help="A machine id of the store.")
@_store_option
@_judging_options
def steps(
    suite: str,
    commits: str,
    machine: str | None,
    anchor: str | None,
    store: str,
    threshold: float,
    alpha: float,
) -> None:
    """Print every step of every case the store holds for this machine, suite and anchor."""
    from rich.console import Console

    import harness
    from registry import HarnessError

    console = Console(width=180)
    try:
        tracker = _tracker(store, harness.suite(suite), anchor, machine=machine, console=console)
        found = tracker.steps(tracker.order(commits), threshold=threshold, alpha=alpha)
    except HarnessError as error:
        raise InputError(str(error)) from None
    _print_steps(console, found, tracker.names)


@track.command("publish")
@click.option(
    "--out",
    type=click.Path(file_okay=False, path_type=Path),
    required=True,
    help="Folder of the static site (claimed as the tool's: see README).",
)
@click.option("--suite", default="quick", show_default=True, help="The suite whose samples are shown.")
@click.option(
    "--range",
    "commits",
    default="HEAD",
    show_default=True,
    help="Commits shown, in this order (A..B or a tip: its first parents).",
)
@click.option("--machine", default=None, show_default="this machine", help="A machine id of the store.")
@click.option("--force", is_flag=True, help="Replace an earlier site in --out.")
@_store_option
@_judging_options
def publish(
    out: Path,
    suite: str,
    commits: str,
    machine: str | None,
    force: bool,
    anchor: str | None,
    store: str,
    threshold: float,
    alpha: float,
) -> None:
    """Write a static dashboard: per case its time across commits with the steps marked, the solvers'
    shifted geometric means per commit and their performance profile, and each commit's per-instance
    table."""
    import harness
    from registry import HarnessError
    from reports._dashboard import write_site

    try:
        tracker = _tracker(store, harness.suite(suite), anchor, machine=machine)
        index = write_site(
            tracker, tracker.order(commits), out, threshold=threshold, alpha=alpha, force=force
        )
    except HarnessError as error:
        raise InputError(str(error)) from None
    click.echo(f"dashboard: {index}")


def _print_steps(console: Console, found: list, names: dict[str, str]) -> None:
    """One row per step: case, first commit (and whether it is named for sure), ratio and interval."""
    from rich.table import Table

    if not found:
        console.print("[green]no steps[/]")
        return
    table = Table(
        title="steps",
        caption="ratio: the new level over the old, each commit's CPU time per solve a ratio to the "
        "anchor's; interval: Welch's, over the two levels' replicates",
    )
    for column in ("case", "first commit", "after", "ratio", "interval", "named"):
        table.add_column(column)
    for step in found:
        table.add_row(
            escape(step.case),
            escape(names.get(step.commit, step.commit[:10])),
            escape(names.get(step.previous, step.previous[:10])),
            f"x{step.ratio:.3f}",
            f"[{step.low:.3f}, {step.high:.3f}]",
            "yes" if step.exact else "no: commits between were not measured (--bisect)",
            style="yellow" if step.ratio > 1 else "cyan",
        )
    console.print(table)
