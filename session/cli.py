"""``harness pack``: the artist's command (one rig, one solver, the expressions to scan)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from harness import (
    COUNT,
    DURATION,
    JMAX,
    SOLVER_SEED,
    constraint_options,
    constraint_params,
    packing_options,
    packing_params,
    terminal,
)

if TYPE_CHECKING:
    from rich.console import JustifyMethod

#: The columns of the expressions table and how each is aligned.
_COLUMNS: tuple[tuple[str, JustifyMethod], ...] = (
    ("#", "right"),
    ("shapes", "right"),
    ("objective", "right"),
    ("status", "left"),
    ("blendshapes", "left"),
)


@click.command("pack")
@click.argument("rig")
@click.option(
    "--target",
    type=click.Path(exists=True, dir_okay=False),
    help="The target character's neutral (an OBJ of the same mesh, or a rig file): drives the distortion "
    "importance (eq. 6), and the expressions are also written on it (OUT/on_target/).",
)
@click.option("--solver", default="cpsat", help="Solver plugin (see harness list).")
@click.option("--jmax", type=COUNT, default=JMAX, help="Most expressions (not with --minimum).")
@click.option(
    "--minimum",
    is_flag=True,
    help="The fewest expressions that cover every shape, proven by a lower bound, in importance order "
    "(CP-SAT; --time-limit bounds the proof and each step, default 60s).",
)
@click.option(
    "--out",
    type=click.Path(file_okay=False, path_type=Path),
    required=True,
    help="Session folder: expressions.json, neutral.obj, expression_XX.obj, pictures/, session.html "
    "(never the rig's own folder).",
)
@click.option(
    "--pictures/--no-pictures", default=True, help="Render each expression (front and three-quarter)."
)
@click.option("--glb", is_flag=True, help="Also write expressions.glb: the expressions as morph targets.")
@click.option(
    "--force",
    is_flag=True,
    help="Replace an earlier packing in --out (a folder holding files harness did not write is refused; "
    "those are never replaced or removed).",
)
@packing_options(grid=False)
@click.option(
    "--extra-examples/--no-extra-examples",
    default=False,
    help="Second pass adding already-used shapes where they fit (sec. 6).",
)
@click.option(
    "--time-limit",
    type=DURATION,
    help="Per-solve time limit (30s, 2m); a solver that overruns it is stopped. [default: none]",
)
@click.option(
    "--timeout",
    type=DURATION,
    help="Wall-clock limit for the whole packing (10m): each solve gets at most the time left (a solver that "
    "ignores it is stopped); when it runs out, the expressions found so far are written with a warning "
    "(exit 0), or, with none found, an error. "
    "[default: none]",
)
@click.option(
    "--seed", type=SOLVER_SEED, default=0, help="Solver seed (and generator seed for a preset rig)."
)
@click.option("--refine", is_flag=True, help="Accept or reject each proposed shape at a prompt (sec. 4.5.3).")
@click.option("--reject", help="Rejections without prompts: EXPR:NAME,... (1-based expression numbers).")
@click.option(
    "--exclude",
    multiple=True,
    metavar="SHAPE[,SHAPE]",
    help="Leave shapes out of the whole session (listed in expressions.json's excluded). Repeatable.",
)
@click.option(
    "--default-constraints/--no-default-constraints",
    default=True,
    help="Apply the anatomical rules shipped for ARKit-named shapes (the eyes look the same way, a closed "
    "lid hides the eye, no tongue through closed lips, ...: packing/face_rules.toml) where the rig's names "
    "match.",
)
@constraint_options
def pack(
    rig: str,
    target: str | None,
    solver: str,
    jmax: int,
    minimum: bool,
    out: Path,
    pictures: bool,
    glb: bool,
    force: bool,
    extra_examples: bool,
    time_limit: float | None,
    timeout: float | None,
    seed: int,
    refine: bool,
    reject: str | None,
    exclude: tuple[str, ...],
    default_constraints: bool,
    together: tuple[str, ...],
    apart: tuple[str, ...],
    constraints: Path | None,
    regions: Path | None,
    **packing: Any,
) -> None:
    """Choose the reference expressions of RIG (any rig file or folder, a preset name, or a fetched rig's
    name) and write the scanning session to OUT: expressions.json, neutral.obj and one OBJ per expression
    (template neutral + its shapes, keeping the source OBJ's UVs, normals, groups and materials), the
    pictures and the scan sheet session.html."""
    from rich.markup import escape
    from rich.table import Table

    from harness import expand_names, solver_names
    from session._constraints import parse_exclusions
    from session._files import SHEET_FILE
    from session._pack import EXPRESSIONS_FILE, PackConfig, check_minimum, pack as pack_rig, parse_rejections

    if refine and reject:
        raise click.UsageError("use either --refine (interactive) or --reject (listed), not both")
    context = click.get_current_context()
    given = [
        f"--{name}"
        for name in ("jmax", "solver")
        if context.get_parameter_source(name) is not click.core.ParameterSource.DEFAULT
    ]
    check_minimum(
        minimum, refining=refine or bool(reject), extra_examples=extra_examples, timeout=timeout, given=given
    )
    (solver,) = expand_names([solver], solver_names(), "solver", "--solver")

    def decide(expression: int, shape: str, extra_example: bool) -> bool:
        role = " as an extra example" if extra_example else ""
        return click.confirm(f"expression {expression}: keep {shape}{role}?", default=True)

    params = {
        **packing_params(packing),
        "extra_examples": extra_examples,
        **constraint_params(together, apart, constraints, regions),
    }
    config = PackConfig(
        rig=rig,
        solver=solver,
        out=out,
        params=params,
        jmax=jmax,
        target=target,
        seed=seed,
        time_limit=time_limit,
        timeout=timeout,
        force=force,
        rejections=parse_rejections(reject),
        inputs=(constraints,) if constraints is not None else (),
        minimum=minimum,
        pictures=pictures,
        glb=glb,
        exclude=parse_exclusions(exclude),
        default_constraints=default_constraints,
    )
    result = pack_rig(config, decide=decide if refine else None)
    by = "--minimum (cpsat)" if minimum else solver
    table = Table(title=escape(f"{rig}: {len(result.document['expressions'])} expressions by {by}"))
    for column, justify in _COLUMNS:
        table.add_column(column, justify=justify)
    for index, expression in enumerate(result.document["expressions"], start=1):
        names = escape(", ".join(expression["shapes"]))
        if expression["extra_examples"]:
            names += f" [dim](+ {escape(', '.join(expression['extra_examples']))})[/]"
        table.add_row(
            str(index),
            str(len(expression["shapes"])),
            f"{expression['objective']:.4f}",
            expression["status"],
            names,
        )
    for note in result.notes:
        terminal().print(f"[dim]note: {escape(note)}[/]")
    terminal().print(table)
    for warning in result.warnings:
        terminal().print(f"[yellow]warning:[/] {escape(warning)}")
    meshes = sum(1 for path in result.files if path.suffix == ".obj")
    pngs = sum(1 for path in result.files if path.suffix == ".png")
    written = f"{out / EXPRESSIONS_FILE}, {meshes} OBJ files, {pngs} pictures and {out / SHEET_FILE}"
    terminal().print(escape(f"wrote {written} to {out}"))
