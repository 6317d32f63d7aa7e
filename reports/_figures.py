"""Line plots from records: coverage per expression, transfer RMS vs J (Carrigan et al. 2020, Figs. 9-10)."""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from reports._png import report_style
from reports._tables import expression_rows, ok_cells, rig_label, setting_label, varying_settings

_LINESTYLES = ("-", "--", ":", "-.")
_MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*", "<", ">")


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
            ax.legend(fontsize=7)
    return figure


def rms_figure(records: pd.DataFrame, rig: str) -> Figure:
    """Transfer RMS error against the number of training expressions J (Carrigan et al. 2020, Figs. 9 and 10).

    One panel per (warp, transfer method); one line per solver and importance setting (and any other
    setting that varies in the run). Values are the median over repetitions of the per-vertex RMS of the
    transferred blendshapes against the target's ground truth, in the rig's length units.

    Raises
    ------
    ValueError
        When the run has no successful transfer records for ``rig``.
    """
    settings = varying_settings(records)
    rows = records[(records["kind"] == "transfer") & (records["status"] == "ok") & (records["rig"] == rig)]
    rows = rows[rows["rms"].notna()]
    if rows.empty:
        raise ValueError(f"rms_figure: no successful transfer records for rig {rig!r}")
    styles = _styles(records, settings)
    panels = sorted(rows[["warp", "transfer"]].drop_duplicates().itertuples(index=False, name=None))
    columns = min(len(panels), 2)
    grid_rows = -(-len(panels) // columns)
    with report_style():
        figure = Figure(figsize=(6.4 * columns, 4.4 * grid_rows), layout="constrained")
        axes = figure.subplots(grid_rows, columns, squeeze=False).ravel()
        for ax, (warp, transfer) in zip(axes, panels, strict=False):
            shown = rows[(rows["warp"] == warp) & (rows["transfer"] == transfer)]
            for keys, line in shown.groupby(["solver", *settings], sort=True, dropna=False):
                setting = setting_label(line.iloc[0], settings)
                curve = line.groupby("j")["rms"].median()
                ax.plot(
                    curve.index.to_numpy(dtype=float),
                    curve.to_numpy(dtype=float),
                    label=_label(keys[0], setting),
                    markersize=3,
                    **styles[(keys[0], setting)],
                )
            ax.set_title(f"{rig_label(rig, records['rig'].unique())}, warp {warp}, transfer {transfer}")
            ax.set_xlabel("training expressions J (count)")
            ax.xaxis.set_major_locator(MaxNLocator(integer=True))
            ax.set_ylabel("RMS error per vertex (rig length units)")
            ax.legend(fontsize=7)
        for ax in axes[len(panels) :]:
            ax.set_visible(False)
    return figure
