"""``harness pack``: the artist's command (one rig, one solver, the expressions to scan)."""

from __future__ import annotations

from pathlib import Path

import click
from rich.markup import escape
from rich.table import Table

from harness._cli_types import DURATION, terminal
from harness._pack import EXPRESSIONS_FILE, parse_rejections
from harness._pack import pack as pack_rig


@click.command("pack")
@click.argument("rig")
@click.option(
    "--target",
    type=click.Path(exists=True, dir_okay=False),
    help="OBJ of the target character's neutral (same mesh); drives the distortion importance, eq. 6.",
)
@click.option("--solver", default="cpsat", help="Solver plugin (see harness list).")
@click.option("--jmax", type=click.IntRange(min=1), default=20, help="Most expressions.")
@click.option(
    "--out",
    type=click.Path(file_okay=False, path_type=Path),
    required=True,
    help="Output directory for expressions.json and expression_XX.obj.",
)
@click.option(
    "--mu",
    type=click.FloatRange(0, 1, min_open=True),
    default=0.3,
    help="Binary blendshape threshold, eq. 2.",
)
@click.option("--alpha", type=click.FloatRange(0, 1), default=0.5, help="Importance mix, eq. 4.")
@click.option("--beta", type=click.FloatRange(min=0), default=0.0, help="Uniqueness weight, eq. 4.")
@click.option("--symmetry/--no-symmetry", default=True, help="Force symmetry pairs together (sec. 4.4).")
@click.option(
    "--importance/--no-importance", default=True, help="Importance weights (eq. 4); off = every weight 1."
)
@click.option(
    "--cap", type=click.IntRange(min=1), help="Most shapes per expression (sec. 6). [default: no cap]"
)
@click.option(
    "--extra-examples/--no-extra-examples",
    default=False,
    help="Second pass adding already-used shapes where they fit (sec. 6).",
)
@click.option("--time-limit", type=DURATION, help="Per-solve time limit (30s, 2m). [default: none]")
@click.option(
    "--seed", type=click.IntRange(min=0), default=0, help="Solver seed (and generator seed for a preset rig)."
)
@click.option("--refine", is_flag=True, help="Accept or reject each proposed shape at a prompt (sec. 4.5.3).")
@click.option("--reject", help="Rejections without prompts: EXPR:NAME,... (1-based expression numbers).")
def pack(
    rig: str,
    target: str | None,
    solver: str,
    jmax: int,
    out: Path,
    mu: float,
    alpha: float,
    beta: float,
    symmetry: bool,
    importance: bool,
    cap: int | None,
    extra_examples: bool,
    time_limit: float | None,
    seed: int,
    refine: bool,
    reject: str | None,
) -> None:
    """Choose the reference expressions of RIG (any rig file or folder, or a preset name) and write
    OUT/expressions.json and one OBJ per expression (template neutral + its shapes)."""
    from harness import _plugins as plugins

    if refine and reject:
        raise click.UsageError("use either --refine (interactive) or --reject (listed), not both")
    plugins.expand_names([solver], plugins.solver_names(), "solver", "--solver")

    def decide(expression: int, shape: str) -> bool:
        return click.confirm(f"expression {expression}: keep {shape}?", default=True)

    params = {
        "mu": mu,
        "alpha": alpha,
        "beta": beta,
        "symmetry": symmetry,
        "importance": importance,
        "max_per_expression": cap,
        "extra_examples": extra_examples,
    }
    result = pack_rig(
        rig,
        solver_name=solver,
        out=out,
        jmax=jmax,
        target=target,
        params=params,
        seed=seed,
        time_limit=time_limit,
        rejections=parse_rejections(reject),
        decide=decide if refine else None,
    )
    table = Table(title=escape(f"{rig}: {len(result.document['expressions'])} expressions by {solver}"))
    for column, justify in (
        ("#", "right"),
        ("shapes", "right"),
        ("objective", "right"),
        ("status", "left"),
        ("blendshapes", "left"),
    ):
        table.add_column(column, justify=justify)  # type: ignore[arg-type]
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
    terminal().print(escape(f"wrote {out / EXPRESSIONS_FILE} and {len(result.files) - 1} OBJ files to {out}"))
