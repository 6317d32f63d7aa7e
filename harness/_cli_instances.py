"""``harness instances export``: a reference sequence's subproblems as MPS files and a MIPLIB ``.solu``.

Registered through the ``harness.commands`` entry point ``instances`` (pyproject.toml), like ``report`` and
``compare``; the work is done in `harness._instances` (the files) and `harness._instances_source` (what to
replay). Errors the user can fix (an unknown rig or solver, an ``--out`` that is a file or holds other
files, a solver that fails) end as one line with exit code 2, as for the built-in commands. The reference
solver solves in a worker process of its own (`harness.IsolatedSolver`, as ``harness pack``'s does): a
solver that calls ``sys.exit`` or crashes is a failure of the export, and one that overruns ``--time-limit``
is stopped.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click
from click.core import ParameterSource

from harness._cli_packing import JMAX, PACKING_OPTIONS, packing_options, packing_params
from harness._cli_types import COUNT, DURATION, SOLVER_SEED, terminal
from registry import HarnessError

#: Options that set the packing of a rig argument; a run directory has them in its run.json.
SEQUENCE_OPTIONS = (*(option.name for option in PACKING_OPTIONS), "jmax", "seed")


@click.group(
    "instances", help="Common instances of reference sequences, for solvers in and out of the harness."
)
def instances() -> None:
    """Common instances of reference sequences, for solvers in and out of the harness."""


@instances.command(
    "export",
    help="Run Algorithm 1 on RIG_OR_RUN (a rig as `harness pack` takes it, or a run directory: one sequence "
    "per rig, warp and packing setting of its run.json) with the reference --solver and write every "
    "expression's presolved model (eq. 3) to OUT as RIG-eXX.mps, with instances.solu (MIPLIB: =opt=, "
    "=best=, =inf=) and instances.json.",
)
@click.argument("rig_or_run")
@click.option(
    "--out",
    type=click.Path(path_type=Path),
    required=True,
    help="Output folder: the MPS files, instances.solu and instances.json (never the rig's own folder).",
)
@click.option("--solver", default="cpsat", show_default=True, help="Reference solver (see harness list).")
@click.option(
    "--rig",
    "run_rig",
    help="With a run directory: only this rig of the run (as run.json names it). [default: all]",
)
@click.option(
    "--force",
    is_flag=True,
    help="Replace an earlier export in --out (a folder holding files harness did not write is refused; "
    "those are never replaced or removed).",
)
@packing_options(grid=False)
@click.option("--jmax", type=COUNT, default=JMAX, show_default=True, help="Most expressions (instances).")
@click.option(
    "--time-limit",
    type=DURATION,
    help="Per-solve time limit of the reference solver (30s, 2m); a solve it cuts short is =best= in "
    "instances.solu. With a run directory it replaces the run's. [default: none, or the run's]",
)
@click.option(
    "--seed", type=SOLVER_SEED, default=0, show_default=True,
    help="Solver seed (and generator seed for a preset rig).",
)  # fmt: skip
@click.pass_context
def export(
    ctx: click.Context,
    rig_or_run: str,
    out: Path,
    solver: str,
    run_rig: str | None,
    force: bool,
    jmax: int,
    time_limit: float | None,
    seed: int,
    **packing: Any,
) -> None:
    from harness.cli import UserError

    try:
        written = _export(
            ctx, rig_or_run, out, solver, run_rig, force, time_limit,
            params=packing_params(packing), jmax=jmax, seed=seed,
        )  # fmt: skip
    except (HarnessError, FileNotFoundError, NotADirectoryError, PermissionError) as error:
        lines = [line for line in str(error).strip().splitlines() if line.strip()]
        raise UserError(lines[0] if lines else type(error).__name__) from None
    from rich.markup import escape

    document = written
    counts: dict[str, int] = {}
    for entry in document["instances"]:
        counts[entry["status"]] = counts.get(entry["status"], 0) + 1
    summary = ", ".join(f"{count} ={status}=" for status, count in counts.items())
    terminal().print(
        escape(
            f"wrote {len(document['instances'])} instances of {len(document['sequences'])} sequences by "
            f"{document['solver']} ({summary or 'none'}), instances.solu and instances.json to {out}"
        )
    )


def _export(
    ctx: click.Context,
    argument: str,
    out: Path,
    solver_name: str,
    run_rig: str | None,
    force: bool,
    time_limit: float | None,
    *,
    params: dict[str, object],
    jmax: int,
    seed: int,
):
    from harness import _instances_source as sources, _plugins as plugins
    from harness._instances import export as export_instances
    from harness._isolated import IsolatedSolver

    (solver_name,) = plugins.expand_names([solver_name], plugins.solver_names(), "solver", "--solver")
    if sources.is_run_directory(argument):
        given = [
            f"--{name.replace('_', '-')}"
            for name in SEQUENCE_OPTIONS
            if ctx.get_parameter_source(name) is ParameterSource.COMMANDLINE
        ]
        if given:
            raise HarnessError(
                f"{argument} is a run directory, whose run.json gives the packing: drop {', '.join(given)}"
            )
        chosen = sources.from_run(Path(argument), rig=run_rig, time_limit=time_limit)
    else:
        if run_rig is not None:
            raise HarnessError("--rig picks a rig of a run directory; RIG_OR_RUN is not one")
        chosen = [sources.from_rig(argument, params=params, jmax=jmax, time_limit=time_limit, seed=seed)]
    plugins.check_settings([solver_name], [], solver_option="--solver")
    found = plugins.solver_info(solver_name)
    if not found.available:
        raise HarnessError(f"--solver {solver_name} is unavailable here: {found.reason or found.status}")
    with IsolatedSolver(solver_name) as isolated:  # (as harness pack and a run's cells solve: in a worker)
        result = export_instances(chosen, solver=isolated, out=out, force=force)
    return result.document
