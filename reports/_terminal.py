"""A run's summary in the terminal (``harness show OUT``), with the paper's claims (`reports._claims`)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
from rich import box
from rich.markup import escape
from rich.table import Table

from harness import VARIATION_FIELDS, format_duration, terminal

#: Packing settings a run may vary; `harness show` labels rows by those that do.
_SETTING_COLUMNS: tuple[str, ...] = VARIATION_FIELDS


def print_summary(out: Path) -> None:
    """Print the summary tables of the run in ``out``: cells by status, sequences per solver, transfer
    errors (and their ratio to deformation transfer), the paper's claims held or not, problems."""
    from harness import read_records, read_run

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
    for table in _sequence_tables(records):
        terminal().print(table)
    transfers = records[(records["kind"] == "transfer") & (records["status"] == "ok")]
    if transfers["rms"].notna().any():
        for table in _transfer_tables(transfers[transfers["rms"].notna()], terminal().width):
            terminal().print(table)
    if transfers["frames_l2"].notna().any():
        terminal().print(_frames_table(records))
    if len(transfers):
        terminal().print(_claims_table(records))
    problems = cells[cells["status"] != "ok"]
    if len(problems):
        table = _table(
            "cells that did not finish ok",
            [(c, "left") for c in ("rig", "warp", "solver", "status", "message")],
        )
        for row in problems.itertuples():
            table.add_row(*map(escape, (row.rig, row.warp, row.solver, row.status, row.message or "")))
        terminal().print(table)


def _table(title: str, columns: list[tuple[str, str]]) -> Table:
    """A table whose text columns fold instead of being cut (``justify`` per column: left or right), with
    no rules between columns, so that it reads at 80 columns."""
    table = Table(title=title, title_justify="left", box=box.SIMPLE_HEAD, pad_edge=False)
    for position, (name, justify) in enumerate(columns):  # the first column names the row: never folded
        table.add_column(name, justify=justify, overflow="fold", no_wrap=position == 0)  # type: ignore[arg-type]
    return table


def _sequence_tables(records: pd.DataFrame) -> list[Table]:
    """Per rig and warp (with N and K), per solver: cells, expressions, coverage, first-expression and
    whole-sequence times (median), and how every solve ended (termination; time-limited solves answered by
    Algorithm 2's packing)."""
    cells = records[(records["kind"] == "cell") & (records["status"] == "ok")]
    expressions = records[(records["kind"] == "expression") & records["cell"].isin(cells["cell"])]
    first = expressions[expressions["expression"] == 1]
    first_time = (first["build_time"] + first["solve_time"]).groupby(first["cell"]).first()
    columns = [("solver", "left"), ("cells", "right"), ("expr.", "right"), ("covered", "right")]
    columns += [("first", "right"), ("sequence", "right"), ("analysis", "right"), ("solves", "left")]
    tables = []
    for (rig, warp), of_rig in cells.groupby(["rig", "warp"], sort=True):
        n, k = of_rig["n_vertices"].iloc[0], of_rig["n_shapes"].iloc[0]
        title = f"sequences of {escape(rig)} / {escape(warp)} (N {n}, K {k}; median over repetitions)"
        table = _table(title, columns)
        tables.append(table)
        for solver, group in of_rig.groupby("solver", sort=True):
            table.add_row(
                escape(solver),
                str(len(group)),
                f"{group['n_expressions'].median():g}",
                f"{group['n_covered'].median():g}",
                format_duration(float(first_time.reindex(group["cell"]).median())),
                format_duration(float(group["sequence_time"].median())),
                format_duration(float(group["analysis_time"].median())),
                _terminations(expressions[expressions["cell"].isin(group["cell"])]),
            )
    return tables


def _terminations(expressions: pd.DataFrame) -> str:
    """``48 optimal, 2 time_limit (1 greedy)``: how the solves ended, most common first, with the number of
    time-limited answers that are Algorithm 2's packing (the ``fallback`` column)."""
    counts = expressions["termination"].astype(str).value_counts()
    text = ", ".join(f"{count} {termination}" for termination, count in counts.items())
    fallback = expressions["fallback"].fillna("").astype(str) if "fallback" in expressions else pd.Series([])
    used = fallback[fallback != ""].value_counts()
    return text + "".join(f" ({count} {name})" for name, count in used.items())


def _transfer_tables(transfers: pd.DataFrame, width: int) -> list[Table]:
    """RMS per rig, warp, solver and method at each J (median over repetitions and settings), with its
    ratio to the ``dt`` RMS of the same rig, warp, solver and J when the run has that reference: a column
    per J, or, when those would not fit in ``width`` characters, every J of a row in one folded column."""
    j_values = sorted(int(j) for j in transfers["j"].unique())
    transfers = transfers.assign(setting=_setting_labels(transfers))
    stacked = width < 24 + 15 * len(j_values)
    columns = [("transfer, solver", "left")]
    columns += [("RMS at J (/ dt)", "left")] if stacked else [(f"J={j}", "right") for j in j_values]
    keys = ["rig", "warp", "setting", "transfer", "solver"]
    medians = transfers.groupby([*keys, "j"])["rms"].median()
    tables = []
    for (rig, warp, setting), of_rig in medians.groupby(level=[0, 1, 2], sort=True):
        label = f"{escape(rig)} / {escape(warp)}" + (f", {escape(setting)}" if setting else "")
        table = _table(f"transfer RMS vs J of {label} (rig units; median over repetitions; (/ dt))", columns)
        tables.append(table)
        for (method, solver), series in of_rig.groupby(level=[3, 4], sort=True):
            values = series.droplevel([0, 1, 2, 3, 4])
            reference = medians.get((rig, warp, setting, "dt", solver))
            cells = []
            for j in j_values:
                if j not in values.index:
                    cells.append("-")
                elif method != "dt" and reference is not None and j in reference.index and reference[j] > 0:
                    cells.append(f"{values[j]:.4g} ({values[j] / reference[j]:.2f})")
                else:
                    cells.append(f"{values[j]:.4g}")
            if stacked:
                cells = ["   ".join(f"{j}: {cell}" for j, cell in zip(j_values, cells, strict=True))]
            table.add_row(f"{escape(method)}, {escape(solver)}", *cells)
    return tables


def _frames_table(records: pd.DataFrame) -> Table:
    """Wagner et al.'s Fig. 10 error per rig, transfer and choice of examples at each J
    (`reports._animation.shown_errors`)."""
    from reports._animation import shown_errors

    shown = shown_errors(records)
    table = Table(title="retargeted frames: mean vertex L2 error (rig units; mean over seeds [95% interval])")
    for column in shown.columns:
        table.add_column(str(column), justify="right" if str(column).startswith("J=") else "left")
    for row in shown.itertuples(index=False):
        table.add_row(*(escape("-" if pd.isna(value) else str(value)) for value in row))
    return table


def _setting_labels(rows: pd.DataFrame) -> list[str]:
    """Per row, the packing settings that vary in ``rows`` (``importance off, alpha=0``), else ""."""
    columns = [c for c in _SETTING_COLUMNS if rows[c].astype(object).fillna("none").nunique() > 1]
    labels = []
    for row in rows[columns].itertuples(index=False):
        parts = []
        for column, value in zip(columns, row, strict=True):
            if column in ("symmetry", "importance"):
                parts.append(f"{column} {'on' if value else 'off'}")
            elif isinstance(value, str):
                parts.append(f"{column}={value}")
            else:
                parts.append(f"{column}={'none' if pd.isna(value) else f'{value:g}'}")
        labels.append(", ".join(parts))
    return labels


def _claims_table(records: pd.DataFrame) -> Table:
    """The paper's claims, held or not, with the numbers (`reports._claims`)."""
    from reports._claims import HELD, NOT_HELD, claims_table

    colours = {HELD: "green", NOT_HELD: "red"}
    table = Table(
        title="the paper's claims (Carrigan et al. 2020, sec. 5.2)", title_justify="left", box=box.SIMPLE_HEAD
    )
    table.add_column("claim", ratio=2, overflow="fold")
    table.add_column("measured", ratio=3, overflow="fold")
    table.add_column("verdict", no_wrap=True)
    for row in claims_table(records).itertuples():
        colour = colours.get(row.verdict, "yellow")
        table.add_row(escape(row.claim), escape(row.measured), f"[{colour}]{row.verdict}[/]")
    return table
