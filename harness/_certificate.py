"""The cross-solver certificate of a run: exact solvers that claim optimality on one instance agree, and no
solver's packing beats a bound another one proved (docs/architecture.md: tolerances).

An *instance* is one expression's packing problem within one group of cells (`GROUP_COLUMNS`: the cells that
solve the same problems with different solvers, one repetition each) among the solvers of one overlap
allowance (``max_overlap``: a solver that may let items share vertices, such as ``greedy-overlap``, solves a
relaxation of eq. 3b, whose packings may well beat the bound of the exact problem). Expression 1 is the
same instance for every solver of a group; expression e > 1 is the same instance for two solvers when they
chose the same primary shapes (as sets) for each of the expressions 1..e-1, because Algorithm 1 derives
each problem from the shapes used so far. Extra examples (sec. 6) are never removed from the next problem,
so they do not matter. In a ``replay`` cell (`harness._replay`) expression e is the reference sequence's
instance e whatever the solver chose before, so every replay cell of a group shares all its instances.

Two rules, checked on every instance among the ``ok`` cells:

- **Optimal claims agree.** Every ``optimal`` objective must equal the others within `TOLERANCE`. The
  tie-break perturbation (`packing.tie_break_perturbation`) makes the optimum unique, so exact solvers with
  MIP gap 0 choose the same packing and their recorded objectives (importance sums recomputed by `packing`,
  never reported by the solver) differ only by float64 summation, about 1e-15 relative for a few hundred
  weights in [0, 1]. Packings that matter differ by at least the tie-break's smallest step,
  ``1e-5 / (4 (I + 1))`` (1.2e-9 at I = 2000 items). 1e-9 relative to ``max(1, |objective|)`` lies between
  the two. A claim below another solver's packing (checked valid) is refuted by it, whatever the others
  claim: it is marked, and takes no part in the vote (one plugin claiming a low optimum cannot take the
  reference solver down with it). When the claims left disagree, which solver is wrong is not known: the
  claims that differ from the majority are marked, or every claim when no value has a strict majority.
- **No packing beats a proved bound.** A bound recorded with ``optimal`` or ``time_limit`` is a claim of
  proof; every other solver's packing of that instance was checked valid by the harness, so an objective
  above the bound refutes the bound, and the cell that claimed it is marked. The bound of an ``optimal``
  expression is recorded as its own objective (`solvers.make_solution`), which bounds the perturbed optimum
  only up to the tie-break of its items, so it is allowed ``TIE_BREAK_SCALE`` per chosen shape more.

Marked cells become ``inconsistent``: their part file is rewritten (through the run's folder manifest, as
the run writes it) to their ``cell`` row alone, with the status and a message naming the instance, the
other solver and both values, as an ``invalid`` cell is recorded.
"""

from __future__ import annotations

import itertools
from collections import Counter, defaultdict
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq

from harness._grid import GROUP_COLUMNS
from harness._records import RECORD_SCHEMA, RECORDS_DIR, part_bytes, part_path, read_records, write_listed
from packing import TIE_BREAK_SCALE
from registry import OutputFolder

#: Relative tolerance (to ``max(1, |value|)``) of the comparisons (see the module docstring).
TOLERANCE = 1e-9
#: Status of a cell whose claims another cell's records contradict.
INCONSISTENT = "inconsistent"
#: Terminations whose bound is a claim of proof.
_PROVING = ("optimal", "time_limit")

#: Overlap allowance of a cell recorded before the ``max_overlap`` column (the same for all of them).
_UNRECORDED = -1.0


def _close(a: float, b: float) -> bool:
    return abs(a - b) <= TOLERANCE * max(1.0, abs(a), abs(b))


def instance_keys(expressions: pd.DataFrame, allowances: Mapping[str, float | None]) -> pd.Series:
    """The instance of every expression row, as a number: rows of one instance (the same group values,
    overlap allowance and expression, after the same earlier shapes as sets) get the same number.

    Parameters
    ----------
    expressions : DataFrame
        ``kind == "expression"`` rows of a run's records (`harness.read_records`).
    allowances : mapping
        Cell id -> the ``max_overlap`` of its cell row.

    Returns
    -------
    Series of int, indexed like ``expressions``.

    Notes
    -----
    Grouped and vectorised: O(R log R) for R rows, whatever the number of instances.
    """
    ordered = expressions.sort_values(["cell", "expression"])
    replay = ordered["mode"].eq("replay") if "mode" in ordered else pd.Series(False, index=ordered.index)
    earlier = np.empty(len(ordered), dtype=np.int64)  # a number per distinct tuple of earlier shape sets
    numbers: dict[tuple[int, frozenset[str]], int] = {}
    current, cell_before = 0, None
    for position, (cell, shapes, replayed) in enumerate(
        zip(ordered["cell"], ordered["shapes"], replay, strict=True)
    ):
        if cell != cell_before:
            current, cell_before = 0, cell
        earlier[position] = 0 if replayed else current  # a replay instance is the reference's
        current = numbers.setdefault(
            (current, frozenset(shapes if shapes is not None else ())), len(numbers) + 1
        )
    keys = ordered[list(GROUP_COLUMNS)].astype(object).where(ordered[list(GROUP_COLUMNS)].notna(), "<none>")
    allowance = ordered["cell"].map(lambda cell: allowances.get(cell)).fillna(_UNRECORDED)
    keys = keys.assign(allowance=allowance, expression=ordered["expression"].to_numpy(), earlier=earlier)
    return keys.groupby(list(keys.columns), sort=False, dropna=False).ngroup().reindex(expressions.index)


def violations(records: pd.DataFrame) -> dict[str, list[str]]:
    """The cells each rule marks, with why, over the ``ok`` cells of ``records``.

    Returns
    -------
    dict of str to list of str
        Cell id -> messages (one per contradiction found), for the cells to mark ``inconsistent``.

    Notes
    -----
    Both rules are first checked on every instance at once (grouped maxima and spreads); only the few
    instances where one may fail are looked at row by row, to name the solvers and values.
    """
    cells = records[(records["kind"] == "cell") & (records["status"] == "ok")]
    expressions = records[(records["kind"] == "expression") & records["cell"].isin(cells["cell"])]
    found: dict[str, list[str]] = defaultdict(list)
    if expressions.empty:
        return {}
    allowance = cells["max_overlap"] if "max_overlap" in cells else pd.Series(None, index=cells.index)
    allowances = {
        cell: None if pd.isna(value) else float(value)
        for cell, value in zip(cells["cell"], allowance, strict=True)
    }
    rows = expressions.assign(instance=instance_keys(expressions, allowances))
    for instance in sorted(_suspect_instances(rows)):
        of_instance = rows[rows["instance"] == instance]
        _disagreeing_optima(of_instance, found)
        _refuted_bounds(of_instance, found)
    return dict(found)


def _suspect_instances(rows: pd.DataFrame) -> set[int]:
    """Instances where a rule may fail: an optimal claim below the instance's best packing, optimal claims
    further apart than `TOLERANCE`, or a proved bound below the best packing (each with its slack)."""
    objective = rows["objective"].astype(float)
    best = objective.groupby(rows["instance"]).transform("max")
    scale = TOLERANCE * objective.abs().clip(lower=1.0)
    claims = rows["termination"] == "optimal"
    slack = TIE_BREAK_SCALE * rows["n_chosen"].astype(float)
    refuted = claims & (objective + slack + scale < best)
    claimed = objective.where(claims)
    spread = claimed.groupby(rows["instance"]).transform("max") - claimed.groupby(rows["instance"]).transform(
        "min"
    )
    disagreeing = claims & (spread > TOLERANCE * claimed.abs().clip(lower=1.0))
    bound = rows["bound"].astype(float)
    bound_slack = slack.where(claims, 0.0) + TOLERANCE * bound.abs().clip(lower=1.0)
    beaten = rows["termination"].isin(_PROVING) & bound.notna() & (best > bound + bound_slack)
    return set(rows.loc[refuted | disagreeing | beaten, "instance"])


def _where(row: pd.Series) -> str:
    place = f"rig {row['rig']} (warp {row['warp']}, repetition {row['repetition']})"
    return f"{place} expression {row['expression']}"


def _disagreeing_optima(rows: pd.DataFrame, found: dict[str, list[str]]) -> None:
    """Mark optimal claims that a packing refutes, then, among the others, those outside the strict majority
    of agreeing values (all of them without one)."""
    claims = rows[rows["termination"] == "optimal"]
    best = rows.loc[rows["objective"].idxmax()] if rows["objective"].notna().any() else None
    if best is not None:
        slack = TIE_BREAK_SCALE * claims["n_chosen"] + TOLERANCE * claims["objective"].abs().clip(lower=1.0)
        refuted = claims["objective"] + slack < best["objective"]
        for row in claims[refuted].itertuples():
            found[row.cell].append(
                f"{_where(rows.loc[row.Index])}: {row.solver} claims the optimum {row.objective:.12g}, "
                f"{best['solver']}'s packing reaches {best['objective']:.12g}"
            )
        claims = claims[~refuted]
    values: list[float] = []  # one representative per cluster of agreeing objectives
    cluster = []
    for objective in claims["objective"]:
        match = next((i for i, value in enumerate(values) if _close(value, objective)), None)
        if match is None:
            values.append(objective)
            match = len(values) - 1
        cluster.append(match)
    if len(values) < 2:
        return
    sizes = Counter(cluster).most_common()
    majority = sizes[0][0] if sizes[0][1] > sizes[1][1] else None
    members = list(zip(cluster, claims.itertuples(), strict=True))
    for (mine, row), (theirs, other) in itertools.permutations(members, 2):
        if mine != majority and mine != theirs and (majority is None or theirs == majority):
            found[row.cell].append(
                f"{_where(rows.loc[row.Index])}: {row.solver} claims the optimum {row.objective:.12g}, "
                f"{other.solver} claims {other.objective:.12g}"
                + ("" if majority is not None else " (no majority: every claim is marked)")
            )


def _refuted_bounds(rows: pd.DataFrame, found: dict[str, list[str]]) -> None:
    """Mark the cell whose proved bound another solver's (valid) packing exceeds (an optimal claim's bound
    only when it is above its objective: the objective is `_disagreeing_optima`'s)."""
    proving = rows[rows["termination"].isin(_PROVING) & rows["bound"].notna()]
    proving = proving[(proving["termination"] != "optimal") | (proving["bound"] > proving["objective"])]
    for claim in proving.itertuples():
        slack = TIE_BREAK_SCALE * claim.n_chosen if claim.termination == "optimal" else 0.0
        above = rows[rows["objective"] > claim.bound + slack + TOLERANCE * max(1.0, abs(claim.bound))]
        for other in above.itertuples():
            found[claim.cell].append(
                f"{_where(rows.loc[claim.Index])}: {claim.solver} proves the bound {claim.bound:.12g} "
                f"({claim.termination}), {other.solver}'s packing reaches {other.objective:.12g}"
            )


def certify(out: Path, folder: OutputFolder) -> dict[str, str]:
    """Check the run in ``out`` and rewrite the part file of every marked cell as ``inconsistent``.

    Parameters
    ----------
    out : Path
        The run directory.
    folder : OutputFolder
        Its manifest, held by the running process.

    Returns
    -------
    dict of str to str
        Id -> message of each cell marked now.
    """
    try:
        records = read_records(out)
    except FileNotFoundError:
        return {}
    marked = {}
    for cell, messages in sorted(violations(records).items()):
        table = pq.read_table(part_path(out, cell), schema=RECORD_SCHEMA)
        (row,) = [row for row in table.to_pylist() if row["kind"] == "cell"]
        unique = list(dict.fromkeys(messages))
        message = "; ".join(unique[:3]) + (f"; and {len(unique) - 3} more" if len(unique) > 3 else "")
        row.update(status=INCONSISTENT, message=f"inconsistent with other solvers: {message}")
        write_listed(folder, f"{RECORDS_DIR}/{cell}.parquet", part_bytes(cell, [row]))
        marked[cell] = row["message"]
    return marked
