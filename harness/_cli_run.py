"""``harness run``: the experiment grid, with progress, records, resume and a choice of executor.

Exit codes: 0 when every cell has its records, 1 when cells were lost to the infrastructure (the run is
incomplete; ``--resume`` runs them), 2 for a user error (one line on stderr), 130 on Ctrl-C.
"""

from __future__ import annotations

import errno
import os
import signal
import sys
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import click
from click.core import ParameterSource
from rich.markup import escape

from harness._cli_constraints import constraint_options, grid_constraints
from harness._cli_packing import grid_axes, packing_options
from harness._cli_types import (
    AXIS_COUNT,
    COUNT,
    DURATION,
    JOBS,
    NAMES,
    PLUGINS,
    POSITIVE_INTS,
    SCAN_SEED,
    SEEDS,
    SOLVER_SEED,
    CommaList,
    terminal,
)
from harness._durations import format_duration
from harness._executors import WORKER_WAIT, DaskExecutor, Executor, LocalExecutor
from harness._grid import (
    CLAIM_SOLVERS,
    CLAIM_VARIATIONS,
    DISTORTIONS,
    EXAMPLES,
    PRESETS,
    CellSpec,
    RunConfig,
)
from harness._progress import RichReporter
from harness._records import RecordsWriteError
from harness._run import run_grid
from harness._run_file import RUN_FILE, read_run
from registry import HarnessError, stop_signal

#: Exit code of a run that lost cells to the infrastructure.
EXIT_INCOMPLETE = 1

DEFAULT_JOBS = min(2, os.cpu_count() or 1)


def _one_or_both(
    names: tuple[str, ...], both: tuple[str, ...] | None = None
) -> Callable[[str], tuple[str, ...]]:
    """The parser of an axis given as one of ``names`` or ``both`` (the two of ``both``, by default every
    one of them)."""

    def parse(text: str) -> tuple[str, ...]:
        if text == "both":
            return both or names
        if text not in names:
            raise HarnessError(text)
        return (text,)

    return parse


DISTORTION_NAMES = CommaList(_one_or_both(DISTORTIONS), "distortions (paper, excess or both)")
EXAMPLE_NAMES = CommaList(
    _one_or_both(EXAMPLES, ("scan", "ideal")), "training expressions (scan, ideal, random or both)"
)


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


class RunReporter(RichReporter):
    """`RichReporter` that also prints notices (broken part files set aside) and lost cells."""

    def notice(self, message: str) -> None:
        self.console.print(f"[yellow]{escape(message)}[/]")

    def cell_lost(self, spec: CellSpec, reason: str) -> None:
        self.console.print(f"[red]   lost[/] {escape(spec.label())}: {escape(reason)}")


def _given(ctx: click.Context, grid: Mapping[str, object]) -> dict[str, object]:
    """The grid options given on the command line (not their defaults)."""
    return {
        name: value
        for name, value in grid.items()
        if value is not None and ctx.get_parameter_source(name) is not ParameterSource.DEFAULT
    }


@click.command("run")
@click.option(
    "--preset",
    type=click.Choice(list(PRESETS)),
    default="quick",
    help="Named grid the other options start from. quick: CI smoke run (<= 60 s); paper: the paper's four "
    "rigs with one warp each and all J values; exact: the film rig's 40 largest problems, exact solvers "
    "only, 3 repetitions (where the backends differ); sanity: every shape scanned alone, ideal and "
    "scan-like, ebfr's beta swept (the evaluation's own check); fig10: Wagner et al.'s quantitative "
    "comparison, anacondar against ALM on random or packed examples over five faces; full: every preset, "
    "warp and setting.",
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
    type=PLUGINS,
    help="Solver plugins, comma-separated; all = every registered one (unavailable ones are skipped and "
    "recorded as such). Settings in brackets are a grid axis, each one a case of its own: "
    '"cpsat[workers=1,2],highs[presolve=off]" runs three solvers. [default: all]',
)
@click.option(
    "--transfers",
    type=PLUGINS,
    help="Transfer methods evaluated after each sequence, with settings as for --solvers "
    f"(ebfr[beta=0.1,gcv]). [default: {_preset_help('transfers')}]",
)
@packing_options(grid=True)
@click.option(
    "--distortion",
    type=DISTORTION_NAMES,
    metavar="paper|excess|both",
    help="Triangle distortion in the importance (eq. 6): paper (s_t as printed) or excess (s_t - 2, the "
    "authors' code: 0 for an undistorted triangle); both = a grid axis. [default: paper]",
)
@click.option(
    "--jmax",
    type=COUNT,
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
    "--seeds",
    "seed",
    type=SEEDS,
    help="Seeds of the generated rigs and actors (warps with +character), a grid axis: 3, 0-4 or 0,2,7. "
    "Claims are judged across them. [default: 0]",
)
@click.option(
    "--solver-seed",
    type=SOLVER_SEED,
    help="Solver seed of repetition 0; repetition r uses this + r. [default: 0]",
)
@click.option(
    "--scan-seed",
    type=SCAN_SEED,
    help="Seed of the scan-like training expressions (the evaluation's capture noise and head motion) of "
    "repetition 0; repetition r uses this + r. [default: 0]",
)
@click.option(
    "--repetitions",
    type=AXIS_COUNT,
    help=f"Repetitions of every cell. [default: {_preset_help('repetitions')}]",
)
@click.option(
    "--examples",
    type=EXAMPLE_NAMES,
    metavar="scan|ideal|random|both",
    help="Training expressions of the transfers: scan (the actor is not the linear sum: correctives where "
    "combined shapes meet, scanner noise, head motion removed by rigid alignment; seeded by --scan-seed "
    "plus the repetition, so repetitions are independent sessions), ideal (the exact sums of the "
    "target's blendshapes, as in the paper), random (random 0/1 expressions of the target, exact sums, "
    "instead of the sequence: Wagner et al.'s Fig. 10) or both (scan and ideal); a comma list is a grid "
    "axis. [default: scan; fig10: random,ideal]",
)
@click.option(
    "--frames",
    type=click.IntRange(min=0),
    help="Judge the transfers as Wagner et al.'s Fig. 10: the mean vertex L2 error of this many random "
    "source frames retargeted (column frames_l2) instead of the RMS of the transferred rig; 0 = off. "
    "[default: 0; fig10: 5]",
)
@click.option(
    "--replay",
    is_flag=True,
    default=None,
    help="Beside every cell, a replay cell: its solver on each subproblem of one reference sequence "
    "(Algorithm 1 with cpsat, shared by the cells of a group), one expression row per instance, no "
    "transfers, so that solvers are timed on the same problems.",
)
@click.option(
    "--permutations",
    type=AXIS_COUNT,
    help="Item orders of every cell (a grid axis, as --repetitions): permutation 0 as built, p > 0 the "
    "items shuffled with seed p before the solver sees them (SCIP's PERMUTE). [default: 1]",
)
@click.option(
    "--variations",
    "variations_name",
    type=click.Choice(["claims", "none"]),
    help="Cells off the grid, one setting changed at a time and run with "
    f"{' and '.join(CLAIM_SOLVERS)} only: claims = no importance, alpha 0, alpha 1, no symmetry (what the "
    "paper's claims compare) and the excess distortion. [default: paper: claims; others: none]",
)
@constraint_options
@click.option(
    "--jobs",
    type=JOBS,
    default=DEFAULT_JOBS,
    help="Local worker processes; with --executor dask and no --scheduler, the worker processes of the "
    "Dask cluster started for the run.",
)
@click.option(
    "--executor",
    type=click.Choice(["local", "dask"]),
    default="local",
    help="Where cells run: local worker processes, or Dask (a cluster on this machine, or --scheduler's).",
)
@click.option(
    "--scheduler",
    help="Dask scheduler address (tcp://HOST:PORT), with --executor dask; without it a cluster of --jobs "
    "workers is started on this machine for the run.",
)
@click.option(
    "--worker-wait",
    type=DURATION,
    default=f"{WORKER_WAIT / 60:g}m",
    help="With --executor dask: how long the cluster may have no worker at all before the run gives up on "
    "the cells left (lost: --resume runs them).",
)
@click.option(
    "--out",
    type=click.Path(file_okay=False, path_type=Path),
    help="Run directory (run.json, records/). [default: results/PRESET]",
)
@click.option(
    "--resume",
    type=click.Path(file_okay=False, path_type=Path),
    help="Finish the run in this directory with the configuration in its run.json (grid options given "
    "with it must match it).",
)
@click.option(
    "--force",
    is_flag=True,
    help="Replace a run already in --out (a folder holding files harness did not write is refused; those "
    "are never replaced or removed).",
)
@click.option(
    "--retry-failed",
    is_flag=True,
    help="With --resume: also run again the cells recorded timeout, crashed or error (a new result "
    "replaces the recorded one).",
)
@click.option(
    "--quiet",
    "-q",
    is_flag=True,
    help="No progress bars or per-cell lines (for CI); problems and the summary still print.",
)
def run(
    preset: str,
    together: tuple[str, ...],
    apart: tuple[str, ...],
    constraints: Path | None,
    regions: Path | None,
    variations_name: str | None,
    jobs: int,
    executor: str,
    scheduler: str | None,
    worker_wait: float,
    out: Path | None,
    resume: Path | None,
    force: bool,
    retry_failed: bool,
    quiet: bool,
    **grid: object,
) -> None:
    """Run the grid rigs x warps x solvers x packing parameters x repetitions; record every cell.

    Each cell packs a rig with one solver (Algorithm 1), verifies the sequence with packing.check, and
    transfers the rig with the first J expressions. Part files land in OUT/records/ as cells finish;
    interrupt at any time and continue with --resume OUT. Cells lost to the infrastructure (a killed
    worker, a lost Dask scheduler) end the run incomplete with exit code 1; --resume runs them again.
    """
    ctx = click.get_current_context()
    given = {**grid_axes(ctx, grid), **_given(ctx, grid)}
    constraint_fields, constraint_origins = grid_constraints(together, apart, constraints, regions)
    given.update(constraint_fields)
    if variations_name is not None:
        given["variations"] = CLAIM_VARIATIONS if variations_name == "claims" else ()
    for axis in ("distortion", "examples"):
        if axis in given:
            given[axis] = tuple(dict.fromkeys(name for names in given[axis] for name in names))
    grid.update(given)
    if scheduler and executor != "dask":
        raise click.UsageError("--scheduler is the Dask scheduler's address: give it with --executor dask")
    if resume is not None and out is not None and Path(out) != Path(resume):
        raise click.UsageError("give either --resume OUT or --out OUT, not two different directories")
    target = resume or out or Path("results") / preset
    preset_given = ctx.get_parameter_source("preset") is not ParameterSource.DEFAULT
    config: RunConfig | None = RunConfig(preset=preset, **PRESETS[preset]).with_overrides(**grid)
    if resume is not None:
        config = None
        if (given or preset_given) and (resume / RUN_FILE).is_file():
            stored = RunConfig.from_dict(read_run(resume)["config"])
            base = RunConfig(preset=preset, **PRESETS[preset]) if preset_given else stored
            config = base.with_overrides(**given)

    console = terminal()
    reporter = RunReporter(console, quiet=quiet)

    def make_executor(timeout: float | None) -> Executor:
        if executor == "dask":
            return DaskExecutor(
                scheduler, timeout=timeout, jobs=jobs, worker_wait=worker_wait, notice=reporter.notice
            )
        return LocalExecutor(jobs=jobs, timeout=timeout)

    execution = {"executor": executor, **({"scheduler": scheduler} if scheduler else {"jobs": jobs})}
    try:
        summary = run_grid(
            config,
            target,
            make_executor=make_executor,
            resume=resume is not None,
            force=force,
            reporter=reporter,
            command=["harness", *sys.argv[1:]],
            execution=execution,
            retry_failed=retry_failed,
            constraint_origins=constraint_origins,
        )
    except KeyboardInterrupt:
        left = _where_interrupted(target, resume is not None)
        terminal(stderr=True).print(f"[yellow]interrupted[/]: {left}")
        sys.exit(128 + (stop_signal() or signal.SIGINT))
    except RecordsWriteError as error:
        fix = "free space" if error.errno == errno.ENOSPC else "fix that"
        then = f"finish with: harness run --resume {target}" if (target / RUN_FILE).is_file() else "run again"
        raise HarnessError(f"{error.strerror}; {fix}, then {then}") from None
    counts = (
        ", ".join(f"{status} {count}" for status, count in sorted(summary.statuses.items()))
        or "nothing to do"
    )
    lost = f", lost {len(summary.lost)}" if summary.lost else ""
    console.print(
        f"{summary.total} cells ({summary.already_done} recorded before): {counts}{lost}; "
        f"{format_duration(summary.seconds)}; records in {summary.out}"
    )
    if not summary.complete:
        reason = next(iter(summary.lost.values()))
        terminal(stderr=True).print(
            f"[red]incomplete[/]: {len(summary.lost)} cells lost to the infrastructure "
            f"(first: {escape(reason)}); run them with: harness run --resume {escape(str(target))}"
        )
        sys.exit(EXIT_INCOMPLETE)


def _where_interrupted(target: Path, resuming: bool) -> str:
    """What the stopped run left, as its ``run.json`` says (one this process wrote: an earlier run's,
    still in the folder, says nothing of this one): nothing yet, cells to resume, or a finished run (the
    stop came as its workers closed)."""
    resume = f"resume with harness run --resume {target}"
    try:
        info = read_run(target) if (target / RUN_FILE).is_file() else {}
        state = info.get("state") if (info.get("execution") or {}).get("pid") == os.getpid() else None
    except (HarnessError, OSError, AttributeError):
        state = None
    if state == "complete":
        return f"as its workers closed; the run is complete ({target})"
    if state is not None:
        return f"finished cells are recorded; {resume}"
    return f"before this run recorded anything; {resume}" if resuming else "no cell was recorded"
