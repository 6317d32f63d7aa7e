"""Plots from records: coverage per expression, transfer RMS vs J (Carrigan et al. 2020, Figs. 9-10), and
the solvers' performance profiles and time distributions."""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib import colormaps
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from reports._png import report_style
from reports._summary import (
    RESOLUTION,
    common_times,
    comparisons,
    performance_profile,
    performance_ratios,
)
from reports._tables import (
    FINISHED,
    REFERENCE_TRANSFERS,
    RMS_PARTS,
    expression_rows,
    ok_cells,
    rig_label,
    setting_label,
    solver_groups,
    transfer_medians,
    varying_settings,
)

_LINESTYLES = ("-", "--", ":", "-.")
_MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*", "<", ">")
_REFERENCE_STYLES = {"dt": "--", "delta": ":"}


def _styles(records: pd.DataFrame, settings: list[str]) -> dict[tuple[str, str], dict]:
    """Stable line style per (solver, setting label): colour and marker by solver, dash by setting."""
    solvers = sorted(records["solver"].dropna().unique())
    labels = sorted(
        {setting_label(row, settings) for _, row in records[settings].drop_duplicates().iterrows()}
    )
    return {
        (solver, label): {
            "color": f"C{i % 10}",
            "marker": _MARKERS[i % len(_MARKERS)],
            "linestyle": _LINESTYLES[j % len(_LINESTYLES)],
        }
        for i, solver in enumerate(solvers)
        for j, label in enumerate(labels)
    }


def _label(solver: str, setting: str) -> str:
    return f"{solver} ({setting})" if setting else solver


def coverage_figure(records: pd.DataFrame, rig: str) -> Figure:
    """Shapes covered against the number of expressions: a line per solver (and setting), a panel per warp.

    Parameters
    ----------
    records : DataFrame
        `harness.read_records` of a run.
    rig : str
        The rig to plot (a value of the ``rig`` column).

    Returns
    -------
    matplotlib Figure; the dashed line marks the non-empty shapes that a complete sequence covers.

    Raises
    ------
    ValueError
        When the run has no finished expressions for ``rig``.
    """
    settings = varying_settings(records)
    rows = expression_rows(records)
    rows = rows[(rows["rig"] == rig) & (rows["repetition"] == rows["repetition"].min())]
    if rows.empty:
        raise ValueError(f"coverage_figure: no expression records for rig {rig!r}")
    cells = ok_cells(records)
    cells = cells[cells["rig"] == rig]
    styles = _styles(records, settings)
    warps = sorted(rows["warp"].unique())
    with report_style():
        figure = Figure(figsize=(6.4 * len(warps), 4.2), layout="constrained")
        for ax, warp in zip(
            np.atleast_1d(figure.subplots(1, len(warps), squeeze=False)[0]), warps, strict=True
        ):
            shown = rows[rows["warp"] == warp]
            for keys, line in shown.groupby(["solver", *settings], sort=True, dropna=False):
                setting = setting_label(line.iloc[0], settings)
                line = line.sort_values("expression")
                ax.plot(
                    np.r_[0, line["expression"].to_numpy(dtype=float)],
                    np.r_[0, line["covered"].to_numpy(dtype=float)],
                    label=_label(keys[0], setting),
                    markersize=3,
                    **styles[(keys[0], setting)],
                )
            coverable = cells[cells["warp"] == warp]
            if not coverable.empty:
                ax.axhline(
                    float((coverable["n_shapes"] - coverable["n_empty"]).max()),
                    color="0.4",
                    linestyle="--",
                    linewidth=0.8,
                    label="non-empty shapes",
                )
            ax.set_title(f"{rig_label(rig, records['rig'].unique())}, warp {warp}")
            ax.set_xlabel("expressions (count)")
            ax.xaxis.set_major_locator(MaxNLocator(integer=True))
            ax.set_ylabel("shapes covered (count)")
        _legend_outside(figure)
    return figure


def _legend_outside(figure: Figure) -> None:
    """One legend for all panels, to the right of them, where it covers no data."""
    entries: dict[str, object] = {}
    for ax in figure.axes:
        handles, names = ax.get_legend_handles_labels()
        entries.update(zip(names, handles, strict=True))
    if entries:
        figure.legend(list(entries.values()), list(entries), loc="outside right upper", fontsize=7)


def rms_figure(records: pd.DataFrame, rig: str) -> Figure:
    """Transfer RMS error against the number of training expressions J (Carrigan et al. 2020, Figs. 9 and 10).

    One row of panels per (warp, transfer method that learns from the examples), one column each for all
    shapes, the shapes the J expressions cover and the others; one line per solver and setting (the
    settings that vary in the run), each with its own colour, its solver's marker and its setting's dash.
    Solvers whose curves agree at every J share one line, labelled ``a = b (identical)``, instead of
    hiding each other. The references of `REFERENCE_TRANSFERS` (deformation transfer, copying the
    template's deltas), which no packing changes, are horizontal lines in the all-shapes panel. Every y
    axis starts at 0, so that a 0.5% difference looks like one. Values are the median over repetitions of
    the per-vertex RMS against the target's ground truth, in rig units; one legend below the panels.

    Raises
    ------
    ValueError
        When the run has no successful transfer records for ``rig``.
    """
    settings = varying_settings(records)
    medians = transfer_medians(records)
    medians = medians[medians["rig"] == rig]
    if medians.empty:
        raise ValueError(f"rms_figure: no successful transfer records for rig {rig!r}")
    references = medians[medians["transfer"].isin(REFERENCE_TRANSFERS)]
    learned = medians[~medians["transfer"].isin(REFERENCE_TRANSFERS)]
    if learned.empty:  # a run of references only: plot them like any method
        learned, references = medians, medians.iloc[:0]
    styles = _line_styles(learned, settings)
    panels = sorted(learned[["warp", "transfer"]].drop_duplicates().itertuples(index=False, name=None))
    title = rig_label(rig, records["rig"].unique())
    j_values = sorted(int(j) for j in learned["j"].unique())
    with report_style():
        figure = Figure(figsize=(5.0 * len(RMS_PARTS), 3.6 * len(panels) + 1.6), layout="constrained")
        axes = figure.subplots(len(panels), len(RMS_PARTS), squeeze=False)
        for row, (warp, transfer) in zip(axes, panels, strict=True):
            shown = learned[(learned["warp"] == warp) & (learned["transfer"] == transfer)]
            for ax, (part, part_label) in zip(row, RMS_PARTS.items(), strict=True):
                top = _rms_lines(ax, shown, part, settings, styles)
                if part == "rms":
                    top = max(top, _reference_lines(ax, references[references["warp"] == warp]))
                ax.set_ylim(0.0, 1.08 * top if top > 0 else 1.0)
                ax.set_title(f"{title}, warp {warp}, {transfer}: {part_label}")
                ax.set_xlabel("training expressions J (count)")
                ax.set_xticks(j_values)
                ax.set_ylabel("RMS error per vertex (rig length units)")
        legend = {}
        for ax in axes.ravel():
            handles, labels = ax.get_legend_handles_labels()
            legend.update(zip(labels, handles, strict=True))
        if legend:
            figure.legend(
                list(legend.values()), list(legend), loc="outside lower center", ncols=2, fontsize=7
            )
    return figure


def _line_styles(rows: pd.DataFrame, settings: list[str]) -> dict[tuple[str, str], dict]:
    """Per (solver, setting label): a colour of its own, the solver's marker and the setting's dash."""
    solvers = sorted(rows["solver"].dropna().unique())
    labels = sorted({setting_label(row, settings) for _, row in rows[settings].drop_duplicates().iterrows()})
    present = sorted(
        {
            (solver, setting_label(row, settings))
            for solver, (_, row) in zip(rows["solver"], rows[settings].iterrows(), strict=True)
        }
    )
    return {
        (solver, label): {
            "color": colormaps["tab20"](index % 20),
            "marker": _MARKERS[solvers.index(solver) % len(_MARKERS)],
            "linestyle": _LINESTYLES[labels.index(label) % len(_LINESTYLES)],
        }
        for index, (solver, label) in enumerate(present)
    }


def _rms_lines(ax: Axes, shown: pd.DataFrame, part: str, settings: list[str], styles: dict) -> float:
    """One line per setting and group of solvers with identical curves; returns the largest value."""
    top = 0.0
    for _, block in shown.groupby(settings, sort=True, dropna=False) if settings else [((), shown)]:
        block = block[block[part].notna()]
        groups = solver_groups(block, part)
        for label in dict.fromkeys(groups.values()):
            solvers = label.split(" = ")
            curve = block[block["solver"] == solvers[0]].sort_values("j")
            setting = setting_label(curve.iloc[0], settings)
            name = f"{label} (identical)" if len(solvers) > 1 else label
            ax.plot(
                curve["j"].to_numpy(dtype=float),
                curve[part].to_numpy(dtype=float),
                label=_label(name, setting),
                markersize=3,
                **styles[(solvers[0], setting)],
            )
            top = max(top, float(curve[part].max()))
    return top


def _reference_lines(ax: Axes, references: pd.DataFrame) -> float:
    """A horizontal line per reference transfer at its RMS over all shapes; returns the largest value."""
    top = 0.0
    for transfer, block in references.groupby("transfer", sort=True):
        value = float(block["rms"].median())
        ax.axhline(
            value,
            color="0.35",
            linestyle=_REFERENCE_STYLES.get(transfer, "--"),
            linewidth=1.0,
            label=f"{transfer} (reference)",
        )
        top = max(top, value)
    return top


def profile_figure(solves: pd.DataFrame) -> Figure:
    """Dolan-More performance profiles of the solvers on their common instances, a panel per comparison.

    Parameters
    ----------
    solves : DataFrame
        `reports._summary.solve_outcomes` of a run.

    Returns
    -------
    matplotlib Figure: per solver, the fraction of the common instances it solved within a factor tau of
    the fastest solver's time (build + solve), tau on a log axis; a solve that did not count as solved
    (time limit, error, a failed cell, or a heuristic's in the exact comparison) never counts, so a curve
    ends below 1 by the solver's share of unsolved instances.

    Raises
    ------
    ValueError
        When the run has no solves.

    Notes
    -----
    Dolan and More, "Benchmarking optimization software with performance profiles", Math. Program. 91
    (2002).
    """
    if solves.empty:
        raise ValueError("profile_figure: the run has no solves")
    shown = comparisons(solves)
    solvers = sorted(solves["solver"].unique())
    with report_style():
        figure = Figure(figsize=(6.4 * len(shown), 4.4), layout="constrained")
        for ax, comparison in zip(figure.subplots(1, len(shown), squeeze=False)[0], shown, strict=True):
            times = common_times(solves, comparison.solvers, comparison.solved)
            profile = performance_profile(performance_ratios(times))
            end = max(2.0, 1.5 * float(profile.index.max()))
            for solver in comparison.solvers:
                index = solvers.index(solver)
                curve = profile[solver]
                ax.step(
                    np.r_[curve.index.to_numpy(), end],
                    np.r_[curve.to_numpy(), curve.iloc[-1]],
                    where="post",
                    label=solver,
                    color=f"C{index % 10}",
                    linestyle=_LINESTYLES[index // 10 % len(_LINESTYLES)],
                )
            ax.set_xscale("log")
            ax.set_xlim(1.0, end)
            ax.set_ylim(0.0, 1.02)
            ax.set_title(f"{comparison.title}: {len(times)} common instances")
            ax.set_xlabel("tau: time within a factor of the fastest (log)")
            ax.set_ylabel("fraction of instances solved")
        _legend_outside(figure)
    return figure


def distribution_figure(solves: pd.DataFrame) -> Figure:
    """Per solver, the distribution of its solve times over all its instances (log scale).

    Parameters
    ----------
    solves : DataFrame
        `reports._summary.solve_outcomes` of a run.

    Returns
    -------
    matplotlib Figure: a box per solver of the charged build + solve times (whiskers at 1.5 IQR), every solve
    drawn over it as a dot (optimal or completed) or a red cross at the limit it is charged (time limit,
    infeasible, error, failed cell); each tick names the solver and its number of solves. Solves of
    different solvers are different problems after expression 1.

    Raises
    ------
    ValueError
        When the run has no solves.
    """
    if solves.empty:
        raise ValueError("distribution_figure: the run has no solves")
    groups = [(solver, rows) for solver, rows in solves.groupby("solver", sort=True)]
    spread = np.random.default_rng(0)
    with report_style():
        figure = Figure(figsize=(max(6.4, 1.0 * len(groups) + 1.5), 4.6), layout="constrained")
        ax = figure.subplots()
        ax.boxplot(
            [rows["charged"].clip(lower=RESOLUTION).to_numpy() for _, rows in groups],
            showfliers=False,
            widths=0.6,
        )
        for position, (_, rows) in enumerate(groups, start=1):
            finished = rows["outcome"].isin(FINISHED).to_numpy()
            times = rows["charged"].clip(lower=RESOLUTION).to_numpy()
            x = position + spread.uniform(-0.2, 0.2, len(rows))
            ax.plot(x[finished], times[finished], "o", color="C0", alpha=0.4, markersize=2.5)
            ax.plot(x[~finished], times[~finished], "x", color="C3", markersize=5)
        ax.plot([], [], "o", color="C0", markersize=2.5, label="optimal or completed")
        ax.plot([], [], "x", color="C3", markersize=5, label="not solved: charged at the limit")
        ax.set_xticks(
            range(1, len(groups) + 1),
            [f"{solver}\n(n={len(rows)})" for solver, rows in groups],
            rotation=30,
            fontsize=7,
        )
        ax.set_yscale("log")
        ax.set_ylabel("build + solve time per expression (s, log)")
        _legend_outside(figure)
    return figure
