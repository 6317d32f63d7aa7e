"""Progress of `harness run` in the terminal: rich bars with ETA per rig group, one line per finished cell."""

from __future__ import annotations

from collections import Counter
from typing import TYPE_CHECKING

from rich.console import Console
from rich.markup import escape
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TaskID,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)

from harness._durations import format_duration
from harness._grid import NO_WARP, CellSpec

if TYPE_CHECKING:
    from harness._rows import Row

_STATUS_STYLE = {
    "ok": "green",
    "skipped": "yellow",
    "error": "red",
    "timeout": "red",
    "invalid": "magenta",
    "inconsistent": "magenta",
}


def _group(spec: CellSpec) -> str:
    return spec.rig if spec.warp == NO_WARP else f"{spec.rig}/{spec.warp}"


def cell_summary(spec: CellSpec, rows: list[Row]) -> str:
    """One line (rich markup) describing a finished cell."""
    cell = rows[0]
    status = cell["status"]
    style = _STATUS_STYLE.get(status, "white")
    head = f"[{style}]{status:>7}[/] {escape(spec.label())}"
    if status != "ok":
        return f"{head}: {escape(str(cell.get('message', '')))}"
    text = (
        f"{head}: {cell['n_expressions']} expressions, {cell['n_covered']}/{cell['n_shapes']} shapes, "
        f"analysis {format_duration(cell['analysis_time'])}, "
        f"sequence {format_duration(cell['sequence_time'])}{_stops(rows)}"
    )
    transfers = [row for row in rows if row["kind"] == "transfer" and row["status"] == "ok"]
    for name in dict.fromkeys(row["transfer"] for row in transfers):
        last = max((row for row in transfers if row["transfer"] == name), key=lambda row: row["j"])
        text += f", {name} RMS {last['rms']:.4g} at J={last['j']}"
    failed = sum(row["kind"] == "transfer" and row["status"] != "ok" for row in rows)
    if failed:
        text += f", [red]{failed} transfer errors[/]"
    return text


def _stops(rows: list[Row]) -> str:
    """`` (5 of 5 solves time limit, 2 greedy fallbacks)`` (in yellow) for a cell whose solves did not all end
    optimal or completed, so that no time is shown without how its solves ended; empty otherwise."""
    solves = [row for row in rows if row["kind"] == "expression"]
    counts = Counter(str(row.get("termination")) for row in solves)
    stopped = {name: count for name, count in counts.items() if name not in ("optimal", "completed")}
    fallbacks = sum(bool(row.get("fallback")) for row in solves)
    if not stopped and not fallbacks:
        return ""
    parts = [
        f"{count} of {len(solves)} solves {name.replace('_', ' ')}" for name, count in sorted(stopped.items())
    ]
    parts += [f"{fallbacks} greedy fallbacks"] if fallbacks else []
    return f" [yellow]({escape(', '.join(parts))})[/]"


class RichReporter:
    """A `harness._run.Reporter` drawing rich progress bars (overall and per rig group, with ETA) and
    printing one summary line per finished cell; ``quiet`` keeps only the up-front notices."""

    def __init__(self, console: Console, *, quiet: bool = False) -> None:
        self.console = console
        self.quiet = quiet
        self._progress: Progress | None = None
        self._tasks: dict[str, TaskID] = {}
        self._overall: TaskID | None = None

    def begin(self, total: int, done: int, pending: list[CellSpec], skipped: dict[str, str]) -> None:
        for name, reason in skipped.items():
            self.console.print(f"[yellow]skipping solver {escape(name)}[/]: {escape(reason)}")
        if done:
            self.console.print(f"resuming: {done} of {total} cells already recorded, {len(pending)} to run")
        if self.quiet or not pending:
            return
        self._progress = Progress(
            TextColumn("{task.description:<28}"),
            BarColumn(),
            MofNCompleteColumn(),
            TimeElapsedColumn(),
            TextColumn("ETA"),
            TimeRemainingColumn(),
            console=self.console,
            transient=False,
        )
        self._overall = self._progress.add_task("all cells", total=len(pending))
        groups: dict[str, int] = {}
        for spec in pending:
            groups[_group(spec)] = groups.get(_group(spec), 0) + 1
        if len(groups) > 1:
            for name, count in groups.items():
                self._tasks[name] = self._progress.add_task(escape(name), total=count)
        self._progress.start()

    def cell_finished(self, spec: CellSpec, rows: list[Row]) -> None:
        if self.quiet:
            if rows[0]["status"] not in ("ok", "skipped"):
                self.console.print(cell_summary(spec, rows))
            return
        self.console.print(cell_summary(spec, rows))
        if self._progress is not None and self._overall is not None:
            self._progress.advance(self._overall)
            if _group(spec) in self._tasks:
                self._progress.advance(self._tasks[_group(spec)])

    def end(self) -> None:
        if self._progress is not None:
            self._progress.stop()
            self._progress = None
