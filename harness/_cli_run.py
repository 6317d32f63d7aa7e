"""``harness run``: the experiment grid, with progress, records, resume and a choice of executor."""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Any

import click

from harness._cli_types import CAPS, DURATION, FLOATS, NAMES, POSITIVE_INTS, SWITCH, terminal
from harness._durations import format_duration
from harness._executors import DaskExecutor, Executor, LocalExecutor
from harness._grid import PRESETS, RunConfig
from harness._progress import RichReporter
from harness._run import run_grid

DEFAULT_JOBS = min(2, os.cpu_count() or 1)


def _preset_value(preset: str, key: str) -> Any:
    defaults = RunConfig(rigs=(), warps=(), solvers=(), transfers=())
    return PRESETS[preset].get(key, getattr(defaults, key))


def _preset_help(key: str) -> str:
    def show(value: Any) -> str:
        if isinstance(value, tuple):
            return ",".join("none" if item is None else str(item).lower() for item in value)
        if value is None:
            return "none"
        return format_duration(value) if key in ("time_limit", "timeout") else str(value)

    return "; ".join(f"{name}: {show(_preset_value(name, key))}" for name in PRESETS)


@click.command("run")
@click.option(
    "--preset",
    type=click.Choice(list(PRESETS)),
    default="quick",
    help="Named grid the other options start from. quick: CI smoke run (<= 60 s); paper: the paper's four "
    "rigs with one warp each and all J values; full: every preset, warp and setting.",
)
@click.option(
    "--rigs", type=NAMES, help=f"Rig presets or rig files, comma-separated. [default: {_preset_help('rigs')}]"
)
@click.option(
    "--warps",
    type=NAMES,
    help=f"Warp presets applied to make targets, or none. [default: {_preset_help('warps')}]",
)
@click.option(
    "--solvers",
    type=NAMES,
    help="Solver plugins, comma-separated; all = every registered one (unavailable ones are skipped and "
    "recorded as such). [default: all]",
)
@click.option(
    "--transfers",
    type=NAMES,
    help=f"Transfer methods evaluated after each sequence. [default: {_preset_help('transfers')}]",
)
@click.option("--mu", type=FLOATS, help="Binary blendshape threshold(s), eq. 2. [default: 0.3]")
@click.option("--alpha", type=FLOATS, help="Importance mix(es), eq. 4. [default: 0.5]")
@click.option("--beta", type=FLOATS, help="Uniqueness weight(s), eq. 4. [default: 0]")
@click.option(
    "--symmetry",
    type=SWITCH,
    is_flag=False,
    flag_value="on",
    help="Symmetry pairs (sec. 4.4): on, off or both (a grid axis). [default: on]",
)
@click.option("--no-symmetry", "no_symmetry", is_flag=True, help="Same as --symmetry off.")
@click.option(
    "--importance",
    type=SWITCH,
    is_flag=False,
    flag_value="on",
    help="Importance weights (eq. 4): on, off (every weight 1) or both. [default: on; full: both]",
)
@click.option("--no-importance", "no_importance", is_flag=True, help="Same as --importance off.")
@click.option(
    "--cap", type=CAPS, help="Most shapes per expression (sec. 6), comma list; none = no cap. [default: none]"
)
@click.option(
    "--jmax",
    type=click.IntRange(min=1),
    help=f"Most expressions per sequence. [default: {_preset_help('jmax')}]",
)
@click.option(
    "--j-values",
    type=POSITIVE_INTS,
    help="Numbers of expressions J used for transfer, capped by each sequence's length. "
    "[default: 2,4,7,10,15,20,25]",
)
@click.option(
    "--time-limit",
    type=DURATION,
    help=f"Per-solve time limit (30s, 2m, 500ms). [default: {_preset_help('time_limit')}]",
)
@click.option(
    "--timeout",
    type=DURATION,
    help="Per-cell time limit; a cell over it is stopped and recorded as timeout. "
    f"[default: {_preset_help('timeout')}]",
)
@click.option(
    "--seed",
    type=click.IntRange(min=0),
    default=0,
    help="Rig generator seed; solver seed = seed + repetition.",
)
@click.option(
    "--repetitions",
    type=click.IntRange(min=1),
    help=f"Repetitions of every cell. [default: {_preset_help('repetitions')}]",
)
@click.option("--jobs", type=click.IntRange(min=1), default=DEFAULT_JOBS, help="Local worker processes.")
@click.option("--executor", type=click.Choice(["local", "dask"]), default="local", help="Where cells run.")
@click.option("--scheduler", help="Dask scheduler address (tcp://HOST:PORT), with --executor dask.")
@click.option(
    "--out",
    type=click.Path(file_okay=False, path_type=Path),
    help="Run directory (run.json, records/). [default: results/PRESET]",
)
@click.option(
    "--resume",
    type=click.Path(file_okay=False, path_type=Path),
    help="Finish the run in this directory with its stored configuration (grid options are ignored).",
)
@click.option("--force", is_flag=True, help="Overwrite a run already in --out.")
@click.option(
    "--quiet",
    "-q",
    is_flag=True,
    help="No progress bars or per-cell lines (for CI); problems and the summary still print.",
)
def run(
    preset: str,
    no_symmetry: bool,
    no_importance: bool,
    jobs: int,
    executor: str,
    scheduler: str | None,
    out: Path | None,
    resume: Path | None,
    force: bool,
    quiet: bool,
    **grid: Any,
) -> None:
    """Run the grid rigs x warps x solvers x packing parameters x repetitions; record every cell.

    Each cell packs a rig with one solver (Algorithm 1), verifies the sequence with packing.check, and
    transfers the rig with the first J expressions. Part files land in OUT/records/ as cells finish;
    interrupt at any time and continue with --resume OUT.
    """
    if no_symmetry:
        grid["symmetry"] = (False,)
    if no_importance:
        grid["importance"] = (False,)
    if executor == "dask" and not scheduler:
        raise click.UsageError("--executor dask needs --scheduler tcp://HOST:PORT")
    if resume is not None and out is not None and Path(out) != Path(resume):
        raise click.UsageError("give either --resume OUT or --out OUT, not two different directories")
    target = resume or out or Path("results") / preset
    config = RunConfig(preset=preset, **PRESETS[preset]).with_overrides(**grid)

    def make_executor(timeout: float | None) -> Executor:
        if executor == "dask":
            return DaskExecutor(scheduler or "", timeout=timeout)
        return LocalExecutor(jobs=jobs, timeout=timeout)

    console = terminal()
    execution = (
        {"executor": executor, "jobs": jobs}
        if executor == "local"
        else {"executor": executor, "scheduler": scheduler}
    )
    try:
        summary = run_grid(
            config,
            target,
            make_executor=make_executor,
            resume=resume is not None,
            force=force,
            reporter=RichReporter(console, quiet=quiet),
            command=["harness", *sys.argv[1:]],
            execution=execution,
        )
    except KeyboardInterrupt:
        terminal(stderr=True).print(
            f"[yellow]interrupted[/]: finished cells are recorded; resume with harness run --resume {target}"
        )
        sys.exit(130)
    counts = (
        ", ".join(f"{status} {count}" for status, count in sorted(summary.statuses.items()))
        or "nothing to do"
    )
    console.print(
        f"{summary.total} cells ({summary.already_done} recorded before): {counts}; "
        f"{format_duration(summary.seconds)}; records in {summary.out}"
    )
