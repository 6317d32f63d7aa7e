"""The history of CI benchmark figures: a CSV file committed with the code, one row per (run, case, figure).

A figure is one timing of one case of a run (``sequence / median exact solver`` of
``arkit52/none/cpsat``): the case's median sequence time as a ratio to the median exact solver measured in
the same run (`reports._timing`), so that the speed of the machine cancels out; the raw seconds are kept
beside it. Columns (`HISTORY_COLUMNS`):

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
is exactly this format's header and every row parses with a ``case_id``: any other file is refused, never
overwritten.

The spread rule (`spreads`) judges a new ratio against the same figure's history *across commits*, not
across runs: back-to-back runs of one commit share the code and mostly the moment of the machine, so their
agreement says nothing about how much a figure moves from one commit to the next. The runs of one commit are
collapsed to one value, the median of their ratios; a run from a dirty tree, or from no git checkout, stands
for no commit and is left out (it is still recorded and plotted). Over the per-commit values of the last
``window`` commits (in the order of each commit's first run), a new ratio is slower when above
``median + max(k * 1.4826 * MAD, tolerance * median)`` (1.4826 MAD is a robust standard deviation: one
outlier commit does not widen it), faster when below the median by as much, and not judged by the history
when the figure has fewer than ``min_runs`` commits there.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from registry import HarnessError, atomic_write

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

#: Columns that identify one run in a history.
RUN_COLUMNS: tuple[str, ...] = ("date", "commit", "machine")

#: Scale that turns a median absolute deviation into a standard deviation for normally distributed noise.
MAD_SCALE = 1.4826

_HEADER = ",".join(HISTORY_COLUMNS)
_TEXT_COLUMNS = ("date", "commit", "dirty", "machine", "case", "figure", "case_id")
_FLOAT_FORMAT = "%.6g"


class HistoryError(HarnessError):
    """A history file that cannot be used: not in this format, or with rows that do not parse."""


@dataclass(frozen=True)
class Spread:
    """Commit-to-commit spread of one figure's ratio over the last commits of a history, and its limits.

    Attributes
    ----------
    commits : int
        Commits that gave the spread (at most the window), each counted once however many runs it has.
    median : float
        Median over those commits of each commit's median ratio.
    mad : float
        Scaled median absolute deviation (``MAD_SCALE`` x MAD) of the per-commit ratios.
    low, high : float
        A new ratio below ``low`` is faster, above ``high`` slower; in between it is within the spread.
    """

    commits: int
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
    ``seconds`` as float (NaN where the run had none), in file order.

    Raises
    ------
    FileNotFoundError
        When ``path`` does not exist.
    HistoryError
        When the file's first line is not exactly the `HISTORY_COLUMNS` header, a row does not parse or a
        row has no ``case_id``.
    """
    path = Path(path)
    try:
        with path.open(encoding="utf-8", newline="") as stream:
            first = stream.readline().rstrip("\r\n")
    except UnicodeDecodeError:
        raise _not_a_history(path, "not UTF-8 text") from None
    except IsADirectoryError:
        raise _not_a_history(path, "a directory") from None
    if first != _HEADER:
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
    if (frame["case_id"] == "").any():
        raise _not_a_history(path, "a row has no case_id")
    return frame.assign(dirty=flags.astype(bool))[list(HISTORY_COLUMNS)]


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
        byte for byte.
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
    atomic_write(path, before + _rows_text(new))
    return len(new)


def commit_ratios(history: pd.DataFrame) -> pd.DataFrame:
    """Each figure's ratio per commit: the median over the commit's runs, in the order of its first run.

    Parameters
    ----------
    history : DataFrame
        `read_history` of a file. Rows from a dirty tree or without a commit, and rows without a ratio, are
        left out: they stand for no commit.

    Returns
    -------
    DataFrame with ``case_id``, ``figure``, ``commit``, ``date`` (the commit's first run), ``runs`` (how
    many runs it had) and ``ratio`` (their median), sorted by figure and then ``date``.
    """
    rows = history[history["ratio"].notna() & ~history["dirty"] & (history["commit"] != "")]
    per_commit = (
        rows.groupby(["case_id", "figure", "commit"], sort=False)
        .agg(date=("date", "min"), runs=("ratio", "size"), ratio=("ratio", "median"))
        .reset_index()
    )
    return per_commit.sort_values(["case_id", "figure", "date"], kind="stable").reset_index(drop=True)


def spreads(
    history: pd.DataFrame,
    *,
    window: int = 10,
    k: float = 3.0,
    tolerance: float = 0.25,
    min_runs: int = 5,
) -> dict[tuple[str, str], Spread]:
    """Spread of each figure's ratio over its last ``window`` commits in ``history``.

    Parameters
    ----------
    history : DataFrame
        `read_history` of a file, without the run being judged. Each commit counts once, with the median of
        its runs (`commit_ratios`); runs from a dirty tree or without a commit are left out.
    window : int
        Latest commits (in the order of their first run) of a figure that give its spread.
    k : float
        Scaled MADs (robust standard deviations) a ratio may move from the median before it counts.
    tolerance : float
        Least margin, relative to the median: a very steady figure still tolerates this much.
    min_runs : int
        Fewest commits with a ratio a figure needs; figures with fewer get no spread, however many runs
        their commits have.

    Returns
    -------
    dict
        ``(case_id, figure) -> Spread``, with ``high = median + margin`` and ``low = max(median - margin, 0)``
        where ``margin = max(k * MAD_SCALE * MAD, tolerance * median)`` over the per-commit ratios.

    Notes
    -----
    O(R log R) for R history rows.
    """
    result = {}
    for (case_id, figure), of_figure in commit_ratios(history).groupby(["case_id", "figure"], sort=True):
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
