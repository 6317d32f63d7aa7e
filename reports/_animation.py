"""Wagner et al.'s quantitative comparison (AnaConDaR, 2024, sec. 4.4, Fig. 10) from a run's records: the
mean vertex L2 error of retargeted source frames (``frames_l2``, `harness._animation`), per rig, number of
examples J, transfer and choice of examples, with intervals over the run's seeds.

A *choice* of examples is ``random`` (J random expressions of the target, ``--examples random``) or the
solver whose first J packed expressions trained the transfer. Random draws do not depend on the cell's
solver, so their rows are the median over the solvers that ran them. Every seed is another face, actor,
draw of random examples and animation, so intervals are Student's t intervals over seeds (`CONFIDENCE`)
and orderings are judged on the paired difference of two methods (or choices) seed by seed.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from scipy import stats

from reports._png import report_style
from reports._tables import rig_label

#: AnaConDaR, and ALM as Wagner et al. compare it: its patchwise blend of the examples alone.
ANACONDAR, ALM = "anacondar", "anacondar[missing=off,anacon=off]"
#: The same with Table 3's ridge read in face diagonals instead of millimetres
#: (`harness._grid.FIG10_TRANSFERS`).
STIFF_ANACONDAR, STIFF_ALM = "anacondar[lambda_reg=900]", "anacondar[lambda_reg=900,missing=off,anacon=off]"
#: Display names of the transfers of Fig. 10.
NAMES = {
    ANACONDAR: "AnaConDaR",
    ALM: "ALM",
    STIFF_ANACONDAR: "AnaConDaR, ridge 900",
    STIFF_ALM: "ALM, ridge 900",
    "ebfr": "EBFR",
}
RANDOM = "random"
#: Confidence of the intervals over seeds.
CONFIDENCE = 0.95
#: Columns identifying one value of the error, seed included.
_KEYS = ["rig", "warp", "choice", "transfer", "j", "rig_seed"]


def frames_errors(records: pd.DataFrame) -> pd.DataFrame:
    """One ``frames_l2`` per (rig, warp, choice, transfer, J, seed): the median over repetitions and, for
    random examples, over the solvers whose cells drew them."""
    rows = records[
        (records["kind"] == "transfer") & (records["status"] == "ok") & records["frames_l2"].notna()
    ]
    if rows.empty:
        return pd.DataFrame(columns=[*_KEYS, "frames_l2"])
    rows = rows.assign(choice=np.where(rows["examples"] == RANDOM, RANDOM, rows["solver"]))
    return rows.groupby(_KEYS, dropna=False)["frames_l2"].median().astype(float).reset_index()


def _interval(values: np.ndarray) -> tuple[float, float, float]:
    """Mean and the `CONFIDENCE` t interval of ``values`` (NaN bounds for fewer than two)."""
    mean = float(np.mean(values))
    if len(values) < 2:
        return mean, np.nan, np.nan
    half = stats.t.ppf(0.5 + CONFIDENCE / 2, len(values) - 1) * np.std(values, ddof=1) / np.sqrt(len(values))
    return mean, mean - half, mean + half


def error_table(records: pd.DataFrame) -> pd.DataFrame:
    """Per rig, warp, choice, transfer and J: the mean ``frames_l2`` over seeds, its interval and the
    number of seeds (rig units)."""
    errors = frames_errors(records)
    rows = []
    for key, block in errors.groupby(_KEYS[:-1], sort=True):
        mean, low, high = _interval(block["frames_l2"].to_numpy())
        rows.append((*key, mean, low, high, len(block)))
    return pd.DataFrame(rows, columns=[*_KEYS[:-1], "mean", "low", "high", "seeds"])


def paired_table(records: pd.DataFrame, first: tuple[str, str], second: tuple[str, str]) -> pd.DataFrame:
    """Per rig, warp and J: ``first`` minus ``second`` (each a (choice, transfer)) seed by seed, as the mean
    difference, its interval, the mean relative to ``second`` and a verdict: ``first lower`` when the
    whole interval is below 0, ``second lower`` when above, else ``unclear``."""
    errors = frames_errors(records).set_index(_KEYS)["frames_l2"]
    rows = []
    if errors.empty:
        return pd.DataFrame(columns=["rig", "warp", "j", "difference", "low", "high", "relative", "verdict"])
    table = errors.unstack(["choice", "transfer"])
    if first not in table or second not in table:
        return pd.DataFrame(columns=["rig", "warp", "j", "difference", "low", "high", "relative", "verdict"])
    both = table[[first, second]].dropna()
    for (rig, warp, j), block in both.groupby(level=["rig", "warp", "j"], sort=True):
        difference = (block[first] - block[second]).to_numpy()
        mean, low, high = _interval(difference)
        verdict = "first lower" if high < 0 else "second lower" if low > 0 else "unclear"
        relative = mean / float(block[second].mean())
        rows.append((rig, warp, int(j), mean, low, high, relative, verdict))
    return pd.DataFrame(
        rows, columns=["rig", "warp", "j", "difference", "low", "high", "relative", "verdict"]
    )


def shown_errors(records: pd.DataFrame) -> pd.DataFrame:
    """`error_table` for reading: a row per rig, warp, transfer and choice, a column per J, each cell the
    mean and its interval, ``0.123 [0.101, 0.145]``."""
    table = error_table(records)
    if table.empty:
        return pd.DataFrame()
    table = table.assign(
        value=[
            f"{mean:.4g} [{low:.4g}, {high:.4g}]" if np.isfinite(low) else f"{mean:.4g}"
            for mean, low, high in zip(table["mean"], table["low"], table["high"], strict=True)
        ],
        transfer=table["transfer"].map(lambda name: NAMES.get(name, name)),
    )
    shown = table.pivot_table(
        index=["rig", "warp", "transfer", "choice"], columns="j", values="value", aggfunc="first"
    )
    shown.columns = [f"J={j}" for j in shown.columns]
    return shown.reset_index()


def shown_paired(records: pd.DataFrame, first: tuple[str, str], second: tuple[str, str]) -> pd.DataFrame:
    """`paired_table` for reading, the verdict naming the lower of the two."""
    table = paired_table(records, first, second)
    names = {"first lower": _name(*first), "second lower": _name(*second), "unclear": "unclear"}
    return table.assign(
        difference=[
            f"{mean:+.4g} [{low:+.4g}, {high:+.4g}]"
            for mean, low, high in zip(table["difference"], table["low"], table["high"], strict=True)
        ],
        relative=[f"{value:+.1%}" for value in table["relative"]],
        verdict=table["verdict"].map(names),
    ).drop(columns=["low", "high"])


def _name(choice: str, transfer: str) -> str:
    """``AnaConDaR (random)``: a transfer's display name and its choice of examples, lower."""
    return f"{NAMES.get(transfer, transfer)} ({choice}) lower"


#: Fixed colours, so that a transfer or a choice of examples looks the same in every panel.
_COLOURS = {
    ANACONDAR: "C0",
    ALM: "C3",
    STIFF_ANACONDAR: "C2",
    STIFF_ALM: "C1",
    "ebfr": "C4",
    RANDOM: "C7",
    "cpsat": "C0",
    "greedy": "C1",
}


def animation_figure(records: pd.DataFrame) -> Figure:
    """Fig. 10 and its packing counterpart: one column of panels per rig (and warp).

    The first row is Wagner et al.'s Fig. 10: the transfers trained on J random examples, mean vertex L2
    error of the retargeted frames against J with the interval over seeds as error bars. Each further row
    is one transfer trained on random examples against the first J expressions of each solver's packing.

    Raises
    ------
    ValueError
        When the records hold no ``frames_l2`` values.
    """
    table = error_table(records)
    if table.empty:
        raise ValueError("animation_figure: the run has no frames_l2 records (harness run --frames F)")
    columns = sorted(table[["rig", "warp"]].drop_duplicates().itertuples(index=False, name=None))
    order = list(NAMES)
    transfers = sorted(
        table["transfer"].unique(), key=lambda name: (order.index(name) if name in NAMES else 99, name)
    )
    packed = [name for name in transfers if set(table[table["transfer"] == name]["choice"]) - {RANDOM}]
    labels = table["rig"].unique()
    with report_style():
        width = max(4.2 * len(columns), 6.0)
        figure = Figure(figsize=(width, 3.3 * (1 + len(packed)) + 0.8), layout="constrained")
        axes = figure.subplots(1 + len(packed), len(columns), squeeze=False)
        for column, (rig, warp) in enumerate(columns):
            shown = table[(table["rig"] == rig) & (table["warp"] == warp)]
            title = (
                rig_label(rig, labels)
                if len(set(table["warp"])) == 1
                else f"{rig_label(rig, labels)}, {warp}"
            )
            random = shown[shown["choice"] == RANDOM]
            _lines(axes[0, column], random, "transfer", transfers, NAMES)
            axes[0, column].set_title(f"{title}: random examples (Fig. 10)", fontsize=8)
            for row, name in enumerate(packed, start=1):
                own = shown[shown["transfer"] == name]
                choices = sorted(own["choice"].unique(), key=lambda choice: (choice == RANDOM, choice))
                _lines(axes[row, column], own, "choice", choices, {})
                axes[row, column].set_title(f"{title}: {NAMES.get(name, name)}, random or packed", fontsize=8)
        for ax in axes.ravel():
            ax.set_xlabel("target examples J (count)")
            ax.set_ylabel("mean vertex L2 error (rig units)")
            ax.set_ylim(bottom=0.0)
            if ax.get_legend_handles_labels()[0]:
                ax.legend(fontsize=7)
    return figure


def _lines(ax, rows: pd.DataFrame, by: str, values: list[str], names: dict[str, str]) -> None:
    """One line with interval bars per value of ``by`` (in the order of ``values``), against J."""
    for index, value in enumerate(values):
        block = rows[rows[by] == value].sort_values("j")
        if block.empty:
            continue
        j = block["j"].to_numpy(dtype=float)
        mean = block["mean"].to_numpy()
        spread = np.vstack([mean - block["low"].to_numpy(), block["high"].to_numpy() - mean])
        ax.errorbar(
            j + 0.25 * (index - 1),
            mean,
            yerr=np.nan_to_num(spread),
            label=names.get(value, value),
            color=_COLOURS.get(value),
            marker="os^Dv"[index % 5],
            markersize=3,
            capsize=2,
        )
