"""The history of CI benchmark figures: a CSV file, committed with the code, with one row per (run, figure).

A figure is one timing of one case of a run (``first expression / naive-pulp-cbc`` of
``arkit52/none/cpsat``) as a ratio to the reference solver's time measured in the same run, so that the
speed of the machine cancels out; the raw seconds are kept beside it. Columns (`HISTORY_COLUMNS`):

- ``date``: when the run started (ISO 8601, UTC, from its ``run.json``)
- ``commit``, ``dirty``: the git commit the run ran from, and whether the tree had uncommitted changes
- ``machine``: host, CPU count, processor and Python of the run
- ``case``, ``figure``: what was timed, named as ``harness compare`` names it
- ``ratio``, ``seconds``: the figure as a ratio to the reference, and in seconds
- ``case_id``: which case was timed, whatever its run: every column that tells cases apart, spelled out
  (`reports._compare.case_id`). The ``case`` label shows only what varies within its run, so two grids can
  label different cases alike; a figure's runs are the rows of one ``case_id``.

A run is identified by (``date``, ``commit``, ``machine``); appending a run twice adds nothing. The file is
only ever rewritten whole and atomically, with the earlier rows byte for byte, and only when its first line
is this format's header or the earlier one without ``case_id`` (`LEGACY_COLUMNS`): any other file is
refused, never overwritten. Appending to a file of the earlier format writes the current header in place of
its first line and keeps its rows, which read with an empty ``case_id``: such a row stands for the case its
label names in the run being judged (`identify_legacy_rows`).

The spread rule (`spreads`) judges a new ratio against the same figure's last runs: it is slower when above
``median + max(k * 1.4826 * MAD, tolerance * median)`` (1.4826 MAD is a robust standard deviation: one
outlier run does not widen it), faster when below the median by as much, and not judged by the history when
the figure has fewer than ``min_runs`` runs there.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from rigs import atomic_write

#: Columns of a history file, in order; its first line is exactly these names joined by commas.
HISTORY_COLUMNS: tuple[str, ...] = (
    "date",
    "commit",
    "dirty",
    "machine",
    "case",
    "figure",
    "ratio",
    "seconds",
    "case_id",
)

#: Columns of the history format before ``case_id``; such a file is still read, and upgraded on append.
LEGACY_COLUMNS: tuple[str, ...] = HISTORY_COLUMNS[:-1]

#: Columns that identify one run in a history.
RUN_COLUMNS: tuple[str, ...] = ("date", "commit", "machine")

#: Scale that turns a median absolute deviation into a standard deviation for normally distributed noise.
MAD_SCALE = 1.4826

_HEADER = ",".join(HISTORY_COLUMNS)
_LEGACY_HEADER = ",".join(LEGACY_COLUMNS)
_TEXT_COLUMNS = ("date", "commit", "dirty", "machine", "case", "figure", "case_id")
_FLOAT_FORMAT = "%.6g"


class HistoryError(ValueError):
    """A history file that cannot be used: not in this format, or with rows that do not parse."""


@dataclass(frozen=True)
class Spread:
    """Run-to-run spread of one figure's ratio over the last runs of a history, and the limits it sets.

    Attributes
    ----------
    runs : int
        Runs that gave the spread (at most the window).
    median : float
        Median ratio over those runs.
    mad : float
        Scaled median absolute deviation (``MAD_SCALE`` x MAD) of the ratio over those runs.
    low, high : float
        A new ratio below ``low`` is faster, above ``high`` slower; in between it is within the spread.
    """

    runs: int
    median: float
    mad: float
    low: float
    high: float


def _not_a_history(path: Path, reason: str) -> HistoryError:
    return HistoryError(f"{path}: not a history file ({reason}); it is left as it is")


def read_history(path: str | os.PathLike) -> pd.DataFrame:
    """Read a history file written by `append_history`.

    Parameters
    ----------
    path : path
        The CSV file.

    Returns
    -------
    DataFrame with the `HISTORY_COLUMNS`: text columns as str, ``dirty`` as bool, ``ratio`` and
    ``seconds`` as float (NaN where the run had none), in file order. Rows written before ``case_id``
    (`LEGACY_COLUMNS`) have an empty one.

    Raises
    ------
    FileNotFoundError
        When ``path`` does not exist.
    HistoryError
        When the file does not start with a history header or a row does not parse.
    """
    path = Path(path)
    try:
        with path.open(encoding="utf-8", newline="") as stream:
            first = stream.readline().rstrip("\r\n")
    except UnicodeDecodeError:
        raise _not_a_history(path, "not UTF-8 text") from None
    except IsADirectoryError:
        raise _not_a_history(path, "a directory") from None
    if first not in (_HEADER, _LEGACY_HEADER):
        raise _not_a_history(path, f"its first line is not {_HEADER!r}")
    text = dict.fromkeys(_TEXT_COLUMNS, str)
    try:
        frame = pd.read_csv(
            path,
            dtype=text | {"ratio": float, "seconds": float},
            keep_default_na=False,
            na_values={"ratio": [""], "seconds": [""]},
        )
    except (ValueError, pd.errors.ParserError) as error:
        raise _not_a_history(path, f"a row does not parse: {error}") from None
    flags = frame["dirty"].map({"True": True, "False": False})
    if flags.isna().any():
        raise _not_a_history(path, "the dirty column holds other values than True and False")
    if "case_id" not in frame.columns:
        frame["case_id"] = ""
    return frame.assign(dirty=flags.astype(bool))[list(HISTORY_COLUMNS)]


def identify_legacy_rows(history: pd.DataFrame, case_ids: Mapping[str, str]) -> pd.DataFrame:
    """``history`` with the rows written before ``case_id`` given one, or dropped.

    Such a row has only its run's label of the case. It stands for the case that the run being judged
    labels alike (``case_ids``: label -> ``case_id``, from `reports.run_figures` of that run); a row whose
    label names no case there is dropped. Rows with a ``case_id`` are kept as they are.

    Parameters
    ----------
    history : DataFrame
        `read_history` of a file.
    case_ids : mapping
        The ``case`` label of each case of the judged run -> its ``case_id``.

    Returns
    -------
    DataFrame with the `HISTORY_COLUMNS`, every ``case_id`` filled.
    """
    legacy = history["case_id"] == ""
    derived = history.loc[legacy, "case"].map(case_ids)
    identified = history.assign(case_id=history["case_id"].where(~legacy, derived))
    return identified[identified["case_id"].notna()].reset_index(drop=True)


def run_identity(run: dict) -> dict[str, object]:
    """The ``date``, ``commit``, ``dirty`` and ``machine`` columns of a run, from its ``run.json``."""
    git = run.get("git") or {}
    machine = run.get("machine") or {}
    return {
        "date": str(run.get("started") or ""),
        "commit": str(git.get("commit") or ""),
        "dirty": bool(git.get("dirty")),
        "machine": f"{machine.get('hostname', '?')}, {machine.get('cpu_count', '?')} CPUs, "
        f"{machine.get('processor') or '?'}, Python {machine.get('python', '?')}",
    }


def _rows_text(rows: pd.DataFrame) -> str:
    return rows[list(HISTORY_COLUMNS)].to_csv(
        index=False, header=False, float_format=_FLOAT_FORMAT, lineterminator="\n"
    )


def append_history(path: str | os.PathLike, rows: pd.DataFrame) -> int:
    """Append the rows of runs not yet in the history file at ``path`` (created when missing).

    Parameters
    ----------
    path : path
        The history file. An existing file must be one (`read_history` accepts it); its rows are kept
        byte for byte, under the current header when it had the earlier one (`LEGACY_COLUMNS`).
    rows : DataFrame
        Rows with the `HISTORY_COLUMNS`, e.g. `reports.run_figures` of a run.

    Returns
    -------
    int
        Rows appended: 0 when every run of ``rows`` is already in the file (which is then not rewritten).

    Raises
    ------
    HistoryError
        When ``path`` exists and is not a history file.
    """
    path = Path(path)
    existing = read_history(path) if path.exists() else pd.DataFrame(columns=list(HISTORY_COLUMNS))
    known = set(existing[list(RUN_COLUMNS)].itertuples(index=False, name=None))
    new = rows[[key not in known for key in rows[list(RUN_COLUMNS)].itertuples(index=False, name=None)]]
    if new.empty:
        return 0
    before = path.read_text(encoding="utf-8") if path.exists() else _HEADER + "\n"
    if not before.endswith("\n"):
        before += "\n"
    if before.startswith(_LEGACY_HEADER + "\n"):
        before = _HEADER + before[len(_LEGACY_HEADER) :]
    atomic_write(path, before + _rows_text(new))
    return len(new)


def spreads(
    history: pd.DataFrame,
    *,
    window: int = 10,
    k: float = 3.0,
    tolerance: float = 0.25,
    min_runs: int = 5,
) -> dict[tuple[str, str], Spread]:
    """Spread of each figure's ratio over its last ``window`` runs in ``history``.

    Parameters
    ----------
    history : DataFrame
        `read_history` of a file, without the run being judged; rows without a ``case_id`` are left out
        (`identify_legacy_rows` gives them one).
    window : int
        Latest runs (by date) of a figure that give its spread.
    k : float
        Scaled MADs (robust standard deviations) a ratio may move from the median before it counts.
    tolerance : float
        Least margin, relative to the median: a very steady figure still tolerates this much.
    min_runs : int
        Fewest runs with a ratio a figure needs; figures with fewer get no spread.

    Returns
    -------
    dict
        ``(case_id, figure) -> Spread``, with ``high = median + margin`` and ``low = max(median - margin, 0)``
        where ``margin = max(k * MAD_SCALE * MAD, tolerance * median)``.

    Notes
    -----
    O(R log R) for R history rows.
    """
    rows = history[history["ratio"].notna() & (history["case_id"] != "")].sort_values("date", kind="stable")
    result = {}
    for (case_id, figure), of_figure in rows.groupby(["case_id", "figure"], sort=True):
        ratios = of_figure["ratio"].tail(window)
        if len(ratios) < min_runs:
            continue
        median = float(ratios.median())
        mad = MAD_SCALE * float((ratios - median).abs().median())
        margin = max(k * mad, tolerance * median)
        result[(case_id, figure)] = Spread(
            len(ratios), median, mad, max(median - margin, 0.0), median + margin
        )
    return result
