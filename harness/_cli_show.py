"""``harness list`` (what is installed) and ``harness show OUT`` (a run's summary in the terminal)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import click
import pandas as pd
from rich.table import Table

from harness import _plugins as plugins
from harness._cli_types import terminal
from harness._durations import format_duration
from harness._grid import PRESETS as RUN_PRESETS


def catalogue() -> dict[str, Any]:
    """Everything `harness list` reports, JSON-ready."""
    import rigs

    return {
        "solvers": [plugins.solver_info(name).as_dict() for name in plugins.solver_names()],
        "transfers": [plugins.transfer_info(name).as_dict() for name in plugins.transfer_names()],
        "rig_presets": sorted(rigs.PRESETS),
        "warps": sorted(rigs.WARPS),
        "run_presets": sorted(RUN_PRESETS),
    }


@click.command("list")
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of tables.")
def list_command(as_json: bool) -> None:
    """Solvers and transfers (availability with the reason, capabilities, versions), rig presets, warps."""
    found = catalogue()
    if as_json:
        click.echo(json.dumps(found, indent=2))
        return
    for kind in ("solvers", "transfers"):
        table = Table(title=kind)
        for column in ("name", "available", "version", "capabilities / reason"):
            table.add_column(column)
        for item in found[kind]:
            flags = ", ".join(name for name, value in item["capabilities"].items() if value is True) or "-"
            detail = flags if item["available"] else f"[yellow]{item['reason']}[/]"
            mark = "[green]yes[/]" if item["available"] else "[red]no[/]"
            table.add_row(item["name"], mark, item["version"] or "-", detail)
        terminal().print(table)
    terminal().print(f"rig presets: {', '.join(found['rig_presets'])}")
    terminal().print(f"warps: {', '.join(found['warps'])}")
    terminal().print(f"run presets: {', '.join(found['run_presets'])}")


@click.command("show")
@click.argument("out", type=click.Path(file_okay=False, path_type=Path))
def show(out: Path) -> None:
    """Summary tables of the run in OUT: cells by status, sequences per solver, transfer errors, problems."""
    from harness._records import read_records
    from harness._run import read_run

    info = read_run(out)
    records = read_records(out)
    config = info["config"]
    terminal().print(
        f"[bold]{out}[/]: {info['state']}, {info['n_cells']} cells, preset {config.get('preset') or '-'}, "
        f"started {info['started']}, finished {info.get('finished') or '-'}, "
        f"git {(info['git'].get('commit') or '-')[:10]}"
    )
    cells = records[records["kind"] == "cell"]
    statuses = cells["status"].value_counts().to_dict()
    missing = info["n_cells"] - len(cells)
    terminal().print(
        "cells: "
        + ", ".join(f"{status} {count}" for status, count in sorted(statuses.items()))
        + (f", not yet run {missing} (harness run --resume {out})" if missing else "")
    )
    terminal().print(_sequence_table(records))
    transfers = records[(records["kind"] == "transfer") & (records["status"] == "ok")]
    if len(transfers):
        terminal().print(_transfer_table(transfers))
    problems = cells[cells["status"] != "ok"]
    if len(problems):
        table = Table(title="cells that did not finish ok")
        for column in ("rig", "warp", "solver", "status", "message"):
            table.add_column(column)
        for row in problems.itertuples():
            table.add_row(row.rig, row.warp, row.solver, row.status, row.message or "")
        terminal().print(table)


def _sequence_table(records: pd.DataFrame) -> Table:
    """Per rig, warp and solver: expressions, coverage, first-expression and whole-sequence times (median)."""
    cells = records[(records["kind"] == "cell") & (records["status"] == "ok")]
    first = records[(records["kind"] == "expression") & (records["expression"] == 1)]
    first_time = (first["build_time"] + first["solve_time"]).groupby(first["cell"]).first()
    table = Table(title="sequences (median over repetitions and parameter settings)")
    for column in (
        "rig",
        "warp",
        "solver",
        "cells",
        "N",
        "K",
        "expressions",
        "covered",
        "first expr.",
        "sequence",
        "analysis",
    ):
        table.add_column(column, justify="left" if column in ("rig", "warp", "solver") else "right")
    for (rig, warp, solver), group in cells.groupby(["rig", "warp", "solver"], sort=True):
        table.add_row(
            rig,
            warp,
            solver,
            str(len(group)),
            str(group["n_vertices"].iloc[0]),
            str(group["n_shapes"].iloc[0]),
            f"{group['n_expressions'].median():g}",
            f"{group['n_covered'].median():g}",
            format_duration(float(first_time.reindex(group["cell"]).median())),
            format_duration(float(group["sequence_time"].median())),
            format_duration(float(group["analysis_time"].median())),
        )
    return table


def _transfer_table(transfers: pd.DataFrame) -> Table:
    """RMS per rig, warp, solver and method at each J (median over repetitions and settings)."""
    j_values = sorted(int(j) for j in transfers["j"].unique())
    table = Table(title="transfer RMS vs J (rig units; median)")
    for column in ("rig", "warp", "transfer", "solver", *(f"J={j}" for j in j_values)):
        table.add_column(column, justify="left" if not column.startswith("J=") else "right")
    medians = transfers.groupby(["rig", "warp", "transfer", "solver", "j"])["rms"].median()
    for (rig, warp, method, solver), series in medians.groupby(level=[0, 1, 2, 3], sort=True):
        values = series.droplevel([0, 1, 2, 3])
        table.add_row(
            rig, warp, method, solver, *(f"{values[j]:.4g}" if j in values.index else "-" for j in j_values)
        )
    return table
