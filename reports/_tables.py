"""Tables read from a run's records: timings (Table 2), agreement of solvers (Table 3), expression counts,
problems, transfer errors against the references, how far apart the packings are.

Every function takes the records DataFrame of `harness.read_records` (or the agreement counts of
`reports._agreement.agreement_counts`) and only selects, groups and formats; nothing is recomputed.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np
import pandas as pd

import harness
import packing
from reports._paper import PAPER_AGREEMENT, PAPER_TIMINGS

#: The solver whose times every other solver's are divided by (measured in the same run).
BASELINE_SOLVER = "naive-pulp-cbc"

#: Columns that identify a group of cells solving the same problems with different solvers: the harness's
#: own grouping of its overlap table, so that reports pair cells exactly as the records do.
GROUP_COLUMNS: tuple[str, ...] = harness.GROUP_COLUMNS

#: Packing parameters of a cell (a "setting"); a report labels lines and rows by those that vary.
SETTING_COLUMNS: tuple[str, ...] = tuple(
    column
    for column in GROUP_COLUMNS
    if column not in ("rig", "rig_seed", "warp", "repetition", "permutation")
)

#: Columns that identify a cell apart from its repetition and permutation.
CASE_COLUMNS: tuple[str, ...] = ("rig", "rig_seed", "warp", *SETTING_COLUMNS, "solver")


def rig_labels(rigs: Iterable[str]) -> dict[str, str]:
    """Short, distinct names of the rigs of a run: a preset name as is, a rig file by its stem
    (``faces/actor.npz`` -> ``actor``), with as many parent folders as it takes to tell it from the others
    (``a/face.npz``, ``b/face.npz`` -> ``a/face``, ``b/face``)."""
    names = list(dict.fromkeys(str(rig) for rig in rigs))
    choices = {name: _label_choices(name) for name in names}
    depth = dict.fromkeys(names, 0)
    while True:
        labels = {name: choices[name][depth[name]] for name in names}
        holders: dict[str, list[str]] = {}
        for name, label in labels.items():
            holders.setdefault(label, []).append(name)
        longer = [
            name
            for group in holders.values()
            if len(group) > 1
            for name in group
            if depth[name] + 1 < len(choices[name])
        ]
        if not longer:
            return labels
        for name in longer:
            depth[name] += 1


def _label_choices(rig: str) -> list[str]:
    """Labels of one rig, shortest first, ending with the full argument."""
    path = Path(rig)
    if len(path.parts) <= 1 and not path.suffix:
        return [rig]
    parts = path.with_suffix("").parts
    return list(dict.fromkeys(["/".join(parts[-n:]) for n in range(1, len(parts) + 1)] + [rig]))


def rig_label(rig: str, among: Iterable[str] = ()) -> str:
    """Short name of ``rig``, distinct from those of the rigs ``among`` (see `rig_labels`)."""
    return rig_labels([str(rig), *among])[str(rig)]


def varying_settings(records: pd.DataFrame) -> list[str]:
    """The setting columns that take more than one value in ``records`` (constant ones need no label)."""
    return [c for c in SETTING_COLUMNS if records[c].astype(object).fillna("none").nunique() > 1]


def setting_label(row: pd.Series | dict, columns: list[str]) -> str:
    """A short human label of the given setting columns of one row, e.g. ``importance off, mu=0.3``."""
    parts = []
    for column in columns:
        value = row[column]
        if column in ("symmetry", "importance"):
            parts.append(f"{column} {'on' if value else 'off'}")
        elif pd.isna(value):
            parts.append(f"no {column}")
        else:
            parts.append(f"{column}={value:g}" if isinstance(value, float) else f"{column}={value}")
    return ", ".join(parts)


#: How a solve ends when it did its work: proved optimal, or a heuristic run to its end. Any other ending
#: (a time limit, an error, a claim of infeasibility) is charged at the solve's limit wherever times are
#: summarised, never counted as fast.
FINISHED: tuple[str, ...] = ("optimal", "completed")


def exact_solvers(solvers: pd.Series, endings: pd.Series) -> set[str]:
    """Solvers that never ended as a heuristic does (``completed``): each claims optimality or fails.

    Parameters
    ----------
    solvers, endings : Series
        One solve each: its solver and how it ended (a `packing.Termination` value, or a failed cell's
        status).
    """
    heuristics = set(solvers[endings.astype(str) == "completed"])
    return {solver for solver in solvers.unique() if solver not in heuristics}


def ok_cells(records: pd.DataFrame) -> pd.DataFrame:
    """The ``cell`` rows of finished cells whose status is ``ok``."""
    return records[(records["kind"] == "cell") & (records["status"] == "ok")]


def expression_rows(records: pd.DataFrame) -> pd.DataFrame:
    """The ``expression`` rows, with ``seconds`` = the sum of the expression's timed steps
    (`packing.EXPRESSION_TIMES`: presolve, build, solve and extra time; null = 0)."""
    rows = records[records["kind"] == "expression"].copy()
    rows["seconds"] = rows[list(packing.EXPRESSION_TIMES)].astype(float).fillna(0.0).sum(axis=1)
    return rows


def termination_counts(solves: pd.DataFrame) -> str:
    """``12 optimal, 3 time_limit (2 greedy fallbacks)``: how some solves ended, most common first, and how
    many of them were answered by Algorithm 2's packing at a time limit (their ``fallback``)."""
    counts = solves["termination"].astype(str).value_counts()
    text = ", ".join(f"{count} {termination}" for termination, count in counts.items())
    if "fallback" in solves:
        fallbacks = int((solves["fallback"].fillna("").astype(str) != "").sum())
        text += f" ({fallbacks} greedy fallbacks)" if fallbacks else ""
    return text


def cell_times(records: pd.DataFrame) -> pd.DataFrame:
    """Per finished cell: first-expression and whole-sequence seconds, and both as ratios to the baseline.

    The ratio divides by `BASELINE_SOLVER`'s time in the cell of the same group (same rig, warp, setting and
    repetition) of the same run, so that machine speed cancels out; it is NaN when the run has no such cell.

    Returns
    -------
    DataFrame with the `GROUP_COLUMNS`, ``solver``, ``n_vertices``, ``n_shapes``, ``analysis_time``,
    ``first_time``, ``sequence_time``, ``first_ratio`` and ``sequence_ratio``.
    """
    cells = ok_cells(records)
    expressions = expression_rows(records)
    first = expressions[expressions["expression"] == 1].set_index("cell")["seconds"]
    keys = [*GROUP_COLUMNS, "solver"]
    times = cells[[*keys, "cell", "n_vertices", "n_shapes", "analysis_time", "sequence_time"]].copy()
    times["first_time"] = times["cell"].map(first).astype(float)
    times["sequence_time"] = times["sequence_time"].astype(float)
    baseline = times[times["solver"] == BASELINE_SOLVER][[*GROUP_COLUMNS, "first_time", "sequence_time"]]
    times = times.merge(baseline, on=list(GROUP_COLUMNS), how="left", suffixes=("", "_baseline"))
    times["first_ratio"] = times["first_time"] / times["first_time_baseline"]
    times["sequence_ratio"] = times["sequence_time"] / times["sequence_time_baseline"]
    return times.drop(columns=["first_time_baseline", "sequence_time_baseline"])


def _median_and_spread(values: pd.Series) -> tuple[float, float]:
    return float(values.median()), float(values.max() - values.min())


_TIMING_COLUMNS = [
    "rig",
    "warp",
    "setting",
    "solver",
    "N",
    "K",
    "repetitions",
    "analysis (s)",
    "first expression (s)",
    "first spread (s)",
    "sequence (s)",
    "sequence spread (s)",
    f"first / {BASELINE_SOLVER}",
    "solves",
]


def timing_table(records: pd.DataFrame) -> pd.DataFrame:
    """Table 2 of Carrigan et al. 2020 for this run, with the paper's published rows beside ours.

    One row per rig (and setting, when several) and solver: N, K, the median over repetitions of the
    rig-analysis, first-expression (presolve + build + solve) and whole-sequence seconds, their spread
    (max - min over repetitions), the median ratio of the first-expression time to `BASELINE_SOLVER`'s and
    how its solves ended (``solves``, `termination_counts`: no time without its time-limit stops).
    For the paper's four rigs (``male``, ``toon``, ``female``, ``digidouble``) two rows follow with the
    published optimal (PuLP with CPLEX) and greedy first-expression times and the paper's N and K.
    """
    times = cell_times(records)
    settings = varying_settings(records)
    labels = rig_labels(times["rig"])
    solves = expression_rows(records)
    rows = []
    for keys, case in times.groupby(["rig", "warp", *settings, "solver"], sort=True, dropna=False):
        rig, warp = keys[0], keys[1]
        first, first_spread = _median_and_spread(case["first_time"])
        sequence, sequence_spread = _median_and_spread(case["sequence_time"])
        rows.append(
            {
                "rig": labels[rig],
                "warp": warp,
                "setting": setting_label(case.iloc[0], settings),
                "solver": keys[-1],
                "N": int(case["n_vertices"].iloc[0]),
                "K": int(case["n_shapes"].iloc[0]),
                "repetitions": len(case),
                "analysis (s)": float(case["analysis_time"].median()),
                "first expression (s)": first,
                "first spread (s)": first_spread,
                "sequence (s)": sequence,
                "sequence spread (s)": sequence_spread,
                f"first / {BASELINE_SOLVER}": float(case["first_ratio"].median()),
                "solves": termination_counts(solves[solves["cell"].isin(case["cell"])]),
            }
        )
    for rig in sorted(set(times["rig"]) & set(PAPER_TIMINGS.index)):
        paper = PAPER_TIMINGS.loc[rig]
        for solver, seconds in (
            ("optimal (PuLP + CPLEX)", paper["optimal_s"]),
            ("greedy", paper["greedy_s"]),
        ):
            rows.append(
                {
                    "rig": rig,
                    "warp": "paper, Table 2",
                    "solver": solver,
                    "N": int(paper["N"]),
                    "K": int(paper["K"]),
                    "first expression (s)": float(seconds),
                }
            )
    table = pd.DataFrame(rows, columns=_TIMING_COLUMNS)
    if not settings:
        table = table.drop(columns="setting")
    return table.sort_values(["rig", "warp"], kind="stable").reset_index(drop=True)


def agreement_table(agreement: pd.DataFrame) -> pd.DataFrame:
    """Table 3 of Carrigan et al. 2020 per solver pair: ``a/b (shared)`` in the first 5, 10, 20 expressions.

    Parameters
    ----------
    agreement : DataFrame
        `agreement_counts`: one row per group, solver pair and ``first``. Repetitions choose the same shapes,
        so only the first repetition of each group is shown.

    Returns
    -------
    DataFrame with rig, warp, the varying settings, ``pair`` (``a/b``) and one column per ``first`` value;
    for the paper's four rigs a ``greedy/optimal`` row with the published figures follows.
    """
    if agreement.empty:
        return pd.DataFrame(columns=["rig", "warp", "pair"])
    settings = varying_settings(agreement)
    first_repetition = agreement[agreement["repetition"] == agreement["repetition"].min()].copy()
    first_repetition["cell"] = [
        f"{a}/{b} ({shared})" if ea == eb == first else f"{a}/{b} ({shared}) [{ea}/{eb} expr.]"
        for a, b, shared, ea, eb, first in first_repetition[
            ["shapes_a", "shapes_b", "shared", "expressions_a", "expressions_b", "first"]
        ].itertuples(index=False)
    ]
    first_repetition["pair"] = first_repetition["solver_a"] + "/" + first_repetition["solver_b"]
    if settings:
        first_repetition["setting"] = [setting_label(row, settings) for _, row in first_repetition.iterrows()]
    index = ["rig", "warp", *(["setting"] if settings else []), "pair"]
    table = first_repetition.pivot_table(index=index, columns="first", values="cell", aggfunc="first")
    table.columns = [f"{first} ex." for first in table.columns]
    table = table.reset_index()
    table["rig"] = table["rig"].map(rig_labels(table["rig"]))
    paper_rows = []
    for rig in sorted(set(table["rig"]) & set(PAPER_AGREEMENT.index.get_level_values("rig"))):
        published = PAPER_AGREEMENT.loc[rig]
        row = {"rig": rig, "warp": "paper, Table 3", "pair": "greedy/optimal"}
        for first, values in published.iterrows():
            row[f"{first} ex."] = f"{values['greedy']}/{values['optimal']} ({values['shared']})"
        paper_rows.append(row)
    table = pd.concat([table, pd.DataFrame(paper_rows)], ignore_index=True)
    return table.sort_values(["rig", "warp"], kind="stable").reset_index(drop=True)


def expression_count_table(records: pd.DataFrame) -> pd.DataFrame:
    """Expressions each solver's sequence used, against the lower bound (and the exact minimum when recorded).

    One row per rig (warp and setting); one column per solver with its sequence length, marked ``+`` when
    the sequence stopped at ``jmax`` before covering every non-empty shape. ``lower bound`` is packing's
    bound (largest conflict clique); ``minimum`` is the proven minimum expression count, or ``<= n`` for the
    best count found within the time limit, when the run recorded one (``min_expressions``).
    """
    cells = ok_cells(records).copy()
    if cells.empty:
        return pd.DataFrame(columns=["rig", "warp", "K", "lower bound"])
    settings = varying_settings(records)
    complete = cells["n_covered"] >= cells["n_shapes"] - cells["n_empty"]
    cells["count"] = [
        f"{count}" if done else f"{count}+"
        for count, done in zip(cells["n_expressions"], complete, strict=True)
    ]
    index = ["rig", "warp", *settings]
    first_repetition = cells[cells["repetition"] == cells["repetition"].min()]
    table = first_repetition.pivot_table(
        index=index, columns="solver", values="count", aggfunc="first", dropna=False
    )
    table.columns = list(table.columns)
    facts = first_repetition.groupby(index, dropna=False).agg(
        K=("n_shapes", "first"), empty=("n_empty", "first"), lower_bound=("lower_bound", "max")
    )
    columns = ["K", "empty", "lower bound"]
    facts = facts.rename(columns={"lower_bound": "lower bound"})
    if "min_expressions" in cells.columns and cells["min_expressions"].notna().any():
        best = first_repetition[first_repetition["min_expressions"].notna()].sort_values(
            ["min_expressions_status", "min_expressions"], key=_proved_first
        )
        facts["minimum"] = best.groupby(index, dropna=False).apply(_minimum_label, include_groups=False)
        columns.append("minimum")
    table = facts[columns].join(table).reset_index()
    table["rig"] = table["rig"].map(rig_labels(table["rig"]))
    if settings:
        table.insert(2, "setting", [setting_label(row, settings) for _, row in table.iterrows()])
        table = table.drop(columns=settings)
    return table


def worst_shapes_table(records: pd.DataFrame) -> pd.DataFrame:
    """The shapes each transfer got most wrong with the most training expressions (largest J), per solver.

    One row per rig, warp, setting, transfer method and solver (first repetition): J, the RMS over all shapes
    and the recorded worst shapes as ``name (rms)``, worst first (Carrigan et al. 2020, sec. 5.2 evaluates
    the same per-vertex RMS).
    """
    rows = records[(records["kind"] == "transfer") & (records["status"] == "ok") & records["rms"].notna()]
    rows = rows[rows["repetition"] == rows["repetition"].min()]
    columns = ["rig", "warp", "transfer", "solver", "J", "RMS", "worst shapes"]
    if rows.empty:
        return pd.DataFrame(columns=columns)
    settings = varying_settings(records)
    last = rows.sort_values("j").groupby(["cell", "transfer"], sort=False).tail(1)
    table = pd.DataFrame(
        {
            "rig": last["rig"].map(rig_labels(records["rig"])),
            "warp": last["warp"],
            "setting": [setting_label(row, settings) for _, row in last.iterrows()],
            "transfer": last["transfer"],
            "solver": last["solver"],
            "J": last["j"],
            "RMS": last["rms"].astype(float),
            "worst shapes": [
                ", ".join(f"{name} ({value:.3g})" for name, value in zip(names, values, strict=True))
                for names, values in zip(last["worst_shapes"], last["worst_rms"], strict=True)
            ],
        }
    )
    if not settings:
        table = table.drop(columns="setting")
    return table.sort_values(["rig", "warp", "transfer", "solver"], kind="stable").reset_index(drop=True)


def _proved_first(column: pd.Series) -> pd.Series:
    return column.map({"optimal": 0}).fillna(1) if column.name == "min_expressions_status" else column


def _minimum_label(cells: pd.DataFrame) -> str:
    """The proven minimum expression count, else ``<= n`` for the best count found within the time limit."""
    best = cells.iloc[0]
    proved = best["min_expressions_status"] == "optimal"
    return f"{best['min_expressions']}" if proved else f"<= {best['min_expressions']}"


def problem_table(records: pd.DataFrame) -> pd.DataFrame:
    """Cells that did not finish ``ok`` (skipped, error, timeout, invalid, inconsistent): how many, with
    their messages."""
    cells = records[(records["kind"] == "cell") & (records["status"] != "ok")]
    columns = ["rig", "warp", "solver", "status", "message"]
    table = cells.groupby(columns, sort=True).size().rename("cells").reset_index()
    table["rig"] = table["rig"].map(rig_labels(records["rig"]))
    return table[["rig", "warp", "solver", "cells", "status", "message"]]


#: Transfers every RMS is reported against: deformation transfer and copying the template's deltas. They
#: ignore the training expressions, so their errors are the same for every solver.
REFERENCE_TRANSFERS: tuple[str, ...] = ("dt", "delta")

#: The RMS columns of a transfer row: over all shapes, shapes some training expression holds, the others.
RMS_PARTS: dict[str, str] = {
    "rms": "all shapes",
    "rms_covered": "covered shapes",
    "rms_uncovered": "uncovered shapes",
}


def transfer_medians(records: pd.DataFrame) -> pd.DataFrame:
    """Per case (`CASE_COLUMNS` minus repetition), transfer and J: the median over repetitions of each RMS
    column (`RMS_PARTS`), the standard deviation of ``rms`` over repetitions (``noise``, NaN for one) and
    the number of repetitions."""
    rows = records[(records["kind"] == "transfer") & (records["status"] == "ok") & records["rms"].notna()]
    keys = [*CASE_COLUMNS, "transfer", "j"]
    if rows.empty:
        return pd.DataFrame(columns=[*keys, *RMS_PARTS, "noise", "repetitions"])
    values = rows[[*keys, *RMS_PARTS]].astype({part: float for part in RMS_PARTS})
    grouped = values.groupby(keys, dropna=False, sort=True)
    medians = grouped[list(RMS_PARTS)].median()
    medians["noise"] = grouped["rms"].std(ddof=1)
    medians["repetitions"] = grouped["rms"].size()
    return medians.reset_index()


def _with_references(medians: pd.DataFrame) -> pd.DataFrame:
    """The medians of the transfers that use examples, with the references' ``rms`` of the same case and J
    as columns ``rms_dt`` and ``rms_delta`` (NaN when the run has no such reference)."""
    keys = [*CASE_COLUMNS, "j"]
    learned = medians[~medians["transfer"].isin(REFERENCE_TRANSFERS)]
    for reference in REFERENCE_TRANSFERS:
        found = medians[medians["transfer"] == reference][[*keys, "rms"]].rename(
            columns={"rms": f"rms_{reference}"}
        )
        learned = learned.merge(found, on=keys, how="left")
    return learned


def solver_groups(block: pd.DataFrame, value: str) -> dict[str, str]:
    """Solver -> label of the solvers whose ``value`` curve over J is identical (``cpsat = highs``)."""
    curves: dict[tuple, list[str]] = {}
    for solver, rows in block.groupby("solver", sort=True):
        key = tuple(np.round(rows.sort_values("j")[["j", value]].to_numpy(dtype=float), 12).ravel())
        curves.setdefault(key, []).append(solver)
    return {solver: " = ".join(group) for group in curves.values() for solver in group}


def rms_table(records: pd.DataFrame, reference: str | None = None, part: str = "rms") -> pd.DataFrame:
    """Transfer RMS against J, absolute or relative to a reference transfer (median over repetitions).

    Parameters
    ----------
    records : DataFrame
    reference : {None, "dt", "delta"}
        None: the RMS itself, with a row per reference transfer; else each RMS divided by the reference's
        RMS over all shapes in the same cell and J (below 1: the training expressions helped).
    part : str
        A column of `RMS_PARTS`.

    Returns
    -------
    DataFrame with rig, warp, the varying settings, transfer, ``solvers`` (solvers whose values agree at
    every J share a row, joined by ``=``) and one ``J=j`` column per J value.
    """
    medians = transfer_medians(records)
    settings = varying_settings(records)
    base = ["rig", "warp", *(["setting"] if settings else []), "transfer", "solvers"]
    learned = _with_references(medians)
    if reference is not None:
        learned = learned.assign(value=learned[part] / learned[f"rms_{reference}"])
        shown = learned
    else:
        references = medians[medians["transfer"].isin(REFERENCE_TRANSFERS)]
        shown = pd.concat([learned, references], ignore_index=True).assign(value=lambda frame: frame[part])
    shown = shown[shown["value"].notna()]
    if shown.empty:
        return pd.DataFrame(columns=base)
    rows = []
    labels = rig_labels(records["rig"])
    for keys, block in shown.groupby(["rig", "warp", *settings, "transfer"], sort=True, dropna=False):
        groups = solver_groups(block, "value")
        if keys[-1] in REFERENCE_TRANSFERS:
            groups = dict.fromkeys(groups, "every solver")
        for label in dict.fromkeys(groups.values()):
            first = next(solver for solver, group in groups.items() if group == label)
            curve = block[block["solver"] == first].set_index("j")["value"]
            row = {
                "rig": labels[keys[0]],
                "warp": keys[1],
                "transfer": keys[-1],
                "solvers": label,
                **{f"J={int(j)}": float(value) for j, value in curve.items()},
            }
            if settings:
                row["setting"] = setting_label(block.iloc[0], settings)
            rows.append(row)
    table = pd.DataFrame(rows)
    j_columns = sorted((c for c in table.columns if c.startswith("J=")), key=lambda c: int(c[2:]))
    return table[[*base, *j_columns]]


def separation_table(records: pd.DataFrame) -> pd.DataFrame:
    """Whether the evaluation tells packings apart: spread of the transfer RMS across packings against the
    run-to-run noise, per rig, warp, transfer and J.

    A packing is a solver with a setting; its value is the median RMS over repetitions. ``spread`` is the
    largest minus the smallest value, ``noise`` the pooled standard deviation over repetitions (the root
    mean of each packing's variance; with scan-like examples every repetition is another capture session),
    and ``spread / noise`` how many noise levels apart the best and the worst packing are. Solvers with
    identical curves count once.

    Returns
    -------
    DataFrame with rig, warp, transfer, J, packings, best, worst, spread, noise, spread / noise, and the
    best and worst RMS. Reference transfers (`REFERENCE_TRANSFERS`) are left out: no packing changes them.
    """
    medians = transfer_medians(records)
    medians = medians[~medians["transfer"].isin(REFERENCE_TRANSFERS)]
    columns = [
        "rig",
        "warp",
        "transfer",
        "J",
        "packings",
        "best",
        "worst",
        "best RMS",
        "worst RMS",
        "spread",
        "noise",
        "spread / noise",
    ]
    if medians.empty:
        return pd.DataFrame(columns=columns)
    settings = varying_settings(records)
    labels = rig_labels(records["rig"])
    rows = []
    for (rig, warp, transfer, j), block in medians.groupby(["rig", "warp", "transfer", "j"], sort=True):
        names = {}
        for _, part in block.groupby(settings, sort=True, dropna=False) if settings else [((), block)]:
            groups = solver_groups(part.assign(j=0), "rms")
            setting = setting_label(part.iloc[0], settings)
            for index, solver in zip(part.index, part["solver"], strict=True):
                names[index] = f"{groups[solver]} ({setting})" if setting else groups[solver]
        packings = block.assign(name=pd.Series(names)).drop_duplicates("name")
        best, worst = packings.loc[packings["rms"].idxmin()], packings.loc[packings["rms"].idxmax()]
        variance = packings["noise"].astype(float) ** 2
        noise = float(np.sqrt(variance.mean())) if variance.notna().all() else float("nan")
        spread = float(worst["rms"] - best["rms"])
        rows.append(
            {
                "rig": labels[rig],
                "warp": warp,
                "transfer": transfer,
                "J": int(j),
                "packings": len(packings),
                "best": best["name"],
                "worst": worst["name"],
                "best RMS": float(best["rms"]),
                "worst RMS": float(worst["rms"]),
                "spread": spread,
                "noise": noise,
                "spread / noise": spread / noise if noise > 0 else float("nan"),
            }
        )
    return pd.DataFrame(rows, columns=columns)
