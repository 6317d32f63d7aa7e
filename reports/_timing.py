"""Timing samples of a run, and how two runs' times of one case are paired for `reports._paired`.

A run's times are noisy: a shared machine, a cold cache, one solve that wanders. A verdict such as "slower"
rests on every sample and on a test (`reports._paired`), with each solver judged against itself:

- **Samples.** Every solve of every repetition of every finished cell is kept (`timing_samples`): the
  seconds of one expression (presolve, build, solve and the rest of its step) and, where the run recorded
  it, the CPU seconds of its solve (`solvers.cpu_seconds`: not the moments the machine gave to another
  job). A solve that did not finish its work (anything but `reports._tables.FINISHED`: a time limit, an
  error) is *charged at the limit* (the row's ``time_limit``), never counted as fast; a repetition stopped
  by the cell's ``--timeout`` is charged the timeout at the expression it was stuck in.
- **Paired instances.** Two runs of one case solve the same problem at expression k when their sequences
  chose the same shapes before it (the same *prefix*): such an expression is one unit, its time on each
  side the median over the run's repetitions (`paired_units`). Expressions whose prefixes differ are left
  out: their problems differ. A case of fewer than `reports._paired.MIN_UNITS` such expressions takes each
  (expression, repetition) as a unit instead, the runs' repetitions matched by number: each is an
  independent measurement of the same problem.
- **One machine.** Seconds measured on two machines say as much about the machines as about the code, so
  times are only judged when both runs name the same host, core count and processor model
  (`reports._compare.one_machine`); ``harness compare --commits`` measures two commits side by side
  instead.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from reports._paired import MIN_UNITS
from reports._tables import CASE_COLUMNS, FINISHED, expression_rows


def _prefixes(rows: pd.DataFrame) -> pd.Series:
    """Per expression row, the shapes its cell chose before it, as one hashable string."""
    ordered = rows.sort_values(["cell", "expression"])
    chosen = ordered["shapes"].map(
        lambda shapes: ",".join(sorted(shapes)) + ";" if shapes is not None else ";"
    )
    before = chosen.groupby(ordered["cell"]).transform(lambda column: column.shift(fill_value="").cumsum())
    return before.reindex(rows.index)


def timing_samples(records: pd.DataFrame) -> pd.DataFrame:
    """One row per solve of every finished cell, with its charged seconds and CPU seconds; a cell stopped
    by ``--timeout`` keeps its finished solves and is charged the rest of its timeout at the expression it
    was stuck in (`_stuck`).

    Parameters
    ----------
    records : DataFrame
        A run's records (`harness.read_records`).

    Returns
    -------
    DataFrame with the `CASE_COLUMNS`, ``repetition``, ``cell``, ``expression``, ``prefix`` (the shapes
    chosen before it),
    ``termination`` (and ``fallback`` when the records have it), ``seconds`` and ``cpu`` (NaN where the run
    did not record it), both charged at the time limit where the solve stopped there or failed.
    """
    cells = records[(records["kind"] == "cell") & records["status"].isin(["ok", "timeout"])]
    rows = expression_rows(records)
    rows = pd.concat([rows[rows["cell"].isin(cells["cell"])], _stuck(cells, rows)], ignore_index=True)
    limit = pd.to_numeric(rows["time_limit"], errors="coerce").astype(float)
    charged = ~rows["termination"].astype(str).isin(FINISHED) & limit.notna()
    cpu = rows["cpu_time"].astype(float) if "cpu_time" in rows else pd.Series(np.nan, index=rows.index)
    rows["seconds"] = np.where(charged, np.fmax(rows["seconds"].astype(float), limit), rows["seconds"])
    rows["cpu"] = np.where(charged & cpu.notna(), np.fmax(cpu, limit), cpu)
    rows["prefix"] = _prefixes(rows)
    ended = ["termination", *(["fallback"] if "fallback" in rows else [])]
    return rows[[*CASE_COLUMNS, "repetition", "cell", "expression", "prefix", *ended, "seconds", "cpu"]]


def _stuck(cells: pd.DataFrame, rows: pd.DataFrame) -> pd.DataFrame:
    """Per cell stopped by ``--timeout`` in its sequence, a row for the expression it was stuck in: the
    next one, charged what the cell's ``sequence_time`` holds beyond its finished expressions
    (`harness._cell.timeout_rows`), with termination ``timeout`` (so, as any solve that did not finish, at
    least its time limit); its prefix is every shape chosen before."""
    stopped = cells[(cells["status"] == "timeout") & cells["sequence_time"].notna()]
    if stopped.empty:
        return stopped
    finished = rows[rows["cell"].isin(stopped["cell"])].groupby("cell")
    spent = finished["seconds"].sum().astype(float)
    reached = finished["expression"].max().astype(float)
    stuck = stopped.copy()
    stuck["seconds"] = stuck["sequence_time"].astype(float) - stuck["cell"].map(spent).astype(float).fillna(
        0.0
    )
    stuck["expression"] = stuck["cell"].map(reached).astype(float).fillna(0.0).astype(int) + 1
    stuck = stuck[stuck["seconds"] > 0].assign(kind="expression", termination="timeout", shapes=None)
    return stuck.assign(cpu_time=stuck["seconds"]) if "cpu_time" in rows else stuck


def clock(old: pd.DataFrame, new: pd.DataFrame) -> str:
    """``cpu`` when both runs' samples of a case all have CPU seconds, else ``seconds``."""
    recorded = all(len(side) and side["cpu"].notna().all() for side in (old, new))
    return "cpu" if recorded else "seconds"


def paired_units(old: pd.DataFrame, new: pd.DataFrame, column: str) -> tuple[pd.DataFrame, str, int]:
    """The units of a case both runs solved on the same problem (module notes), each side's ``column``.

    Returns
    -------
    (units, unit, left_out)
        ``units`` with ``old`` and ``new`` seconds per unit, ``unit`` their name (``expressions``, or
        ``expression repetitions``), ``left_out`` how many expressions only one run solved that way.
    """
    floor = np.finfo(float).tiny
    keys = ["expression", "prefix"]
    sides = [samples.groupby(keys)[column].median().clip(lower=floor) for samples in (old, new)]
    units = pd.concat(sides, axis=1, keys=["old", "new"], join="inner")
    left_out = len(sides[0].index.symmetric_difference(sides[1].index))
    if len(units) >= MIN_UNITS:
        return units, "expressions", left_out
    by_repetition = [
        samples.assign(repetition=samples.groupby(keys)["repetition"].rank(method="first"))
        .set_index([*keys, "repetition"])[column]
        .clip(lower=floor)
        for samples in (old, new)
    ]
    finer = pd.concat(by_repetition, axis=1, keys=["old", "new"], join="inner")
    return finer, "expression repetitions", left_out


def case_samples(samples: pd.DataFrame) -> dict[tuple, pd.DataFrame]:
    """A run's samples by case (`CASE_COLUMNS` values, None for missing)."""
    if samples.empty:
        return {}
    return {
        tuple(None if pd.isna(v) else v for v in key): rows
        for key, rows in samples.groupby(list(CASE_COLUMNS), sort=True, dropna=False)
    }
