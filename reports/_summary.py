"""Solver benchmark summaries across instances: shifted geometric means, outcome counts, wins and
Dolan-More performance profiles, read from a run's records as SCIP's ``check/`` scripts, the MIPLIB 2017
rules and benchopt summarise a benchmark.

An *instance* is one packing problem a solver was given: one expression (``expression``) of one cell group
(`GROUP_COLUMNS`: rig, warp, packing settings and repetition), after a given sequence of earlier
expressions (``prefix``, the shapes chosen before it). A repetition is an instance of its own (the same
problem timed again), so every problem weighs as many samples as the run has repetitions. Sequences of
different solvers diverge once they choose differently, so the instances of two solvers differ after
expression 1: an instance is *common* to a set of solvers when each of them solved exactly that problem,
i.e. expression 1 of a group, or a later expression after identical earlier expressions.

A solve's *time* is the backend's share of the expression, model build + solve (``build_time`` +
``solve_time``): ``solve_time`` alone is 0 when packing's exact reductions leave the backend nothing to
search, and the paper's naive formulation spends most of its time building. A solve that did not end
``optimal`` or ``completed`` (time limit, infeasible, error), and expression 1 of a cell that failed (error,
timeout, crashed, invalid, inconsistent; no expression rows), is *charged* at the time limit, or at what it
took when it overran the limit: never as fast.

Everything here only selects, groups and aggregates recorded values; nothing is recomputed.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.stats import gmean

from reports._tables import FINISHED, GROUP_COLUMNS, exact_solvers

#: Shift of the shifted geometric means, in seconds (see `shifted_geometric_mean`).
SHIFT = 1e-3

#: Relative tolerance within which the fastest solves of an instance tie (each of them wins).
TIE_TOLERANCE = 0.01

#: Times are floored at this many seconds before they are divided (a backend left nothing to do has 0).
RESOLUTION = 1e-6

#: Why a solve ended (the records' ``termination``), then the statuses of cells that failed.
OUTCOMES: tuple[str, ...] = (
    "optimal",
    "completed",
    "time_limit",
    "infeasible",
    "error",
    "timeout",
    "crashed",
    "invalid",
    "inconsistent",
)

#: Cell statuses whose expression 1 counts as a failed solve (a skipped solver ran nothing).
FAILED_CELLS: tuple[str, ...] = ("error", "timeout", "crashed", "invalid", "inconsistent")

#: Columns that identify an instance (see the module docstring).
INSTANCE_COLUMNS: tuple[str, ...] = (*GROUP_COLUMNS, "expression", "prefix")


@dataclass(frozen=True)
class Comparison:
    """Solvers compared on their common instances, and the outcomes that count as solving one."""

    title: str
    solvers: tuple[str, ...]
    solved: frozenset[str]


def shifted_geometric_mean(values: Iterable[float], shift: float = SHIFT) -> float:
    """Shifted geometric mean ``(prod (t_i + s))^(1/n) - s`` of non-negative times.

    Parameters
    ----------
    values : iterable of float
        Times in seconds, at least one.
    shift : float
        The shift ``s`` in seconds. The default, 1 ms, suits this benchmark's solves of 0.01-20 ms: SCIP's
        ``check.awk`` uses 10 s for MIP solves of seconds to hours, so that the many trivial instances do
        not dominate the mean by their relative noise; here differences below about 1 ms are call overhead
        and scheduling noise on a shared machine, which a 1 ms shift damps while a 10 ms solve still weighs
        ten times a trivial one.

    Returns
    -------
    float, in seconds.

    Notes
    -----
    Achterberg, *Constraint Integer Programming* (2007), appendix A; the geometric mean is
    `scipy.stats.gmean`.
    """
    times = np.asarray(list(values), dtype=float)
    return float(gmean(times + shift) - shift)


def _prefixes(rows: pd.DataFrame) -> pd.Series:
    """Per expression row, the shapes chosen by its cell's earlier expressions, as one hashable string."""
    prefixes = {}
    for _, cell in rows.sort_values(["cell", "expression"]).groupby("cell", sort=False):
        earlier: list[tuple[str, ...]] = []
        for index, shapes in zip(cell.index, cell["shapes"], strict=True):
            prefixes[index] = repr(tuple(earlier))
            earlier.append(tuple(sorted(shapes)))
    return pd.Series(prefixes, dtype=object).reindex(rows.index)


def _longest(times: pd.Series) -> float:
    """The longest of ``times``, charged where no limit is known; inf when none was measured."""
    return float(times.max()) if times.notna().any() else np.inf


def _failed_first_solves(records: pd.DataFrame) -> pd.DataFrame:
    """The solve each failed cell did not finish, with the cell's status as its outcome and no time:
    expression 1, or for a cell stopped by its timeout the expression after the ones it recorded."""
    cells = records[(records["kind"] == "cell") & records["status"].isin(FAILED_CELLS)]
    finished = records[(records["kind"] == "expression") & records["cell"].isin(cells["cell"])]
    shapes = finished.sort_values("expression").groupby("cell")["shapes"].agg(list)
    earlier = cells["cell"].map(shapes)
    return cells[[*GROUP_COLUMNS, "cell", "solver"]].assign(
        expression=[1 + len(done) if isinstance(done, list) else 1 for done in earlier],
        prefix=[
            repr(tuple(tuple(sorted(chosen)) for chosen in done)) if isinstance(done, list) else repr(())
            for done in earlier
        ],
        outcome=cells["status"],
        solve_time=np.nan,
        time=np.nan,
    )


def solve_outcomes(records: pd.DataFrame, time_limit: float | None = None) -> pd.DataFrame:
    """Every solve of a run, one row each: its instance, outcome, measured and charged times.

    Parameters
    ----------
    records : DataFrame
        `harness.read_records` of a run.
    time_limit : float, optional
        Seconds charged to an unsolved solve whose row has no ``time_limit`` (the run's per-solve limit,
        else its cell timeout). Without either, the largest time measured in the run is charged (inf when
        nothing was measured).

    Returns
    -------
    DataFrame with the `INSTANCE_COLUMNS`, ``cell``, ``solver``, ``outcome`` (one of `OUTCOMES`),
    ``solve_time`` and ``time`` (build + solve; NaN for a failed cell) as measured, ``limit`` and the
    charged ``charged_solve`` and ``charged`` (the measured times when the outcome is ``optimal`` or
    ``completed``, else the larger of ``limit`` and the measured time) and ``instance``, an integer per
    distinct instance.
    """
    rows = records[records["kind"] == "expression"]
    solved = rows[[*GROUP_COLUMNS, "cell", "solver", "expression"]].assign(
        prefix=_prefixes(rows),
        outcome=rows["termination"],
        solve_time=rows["solve_time"].astype(float),
        time=rows["build_time"].astype(float).fillna(0.0) + rows["solve_time"].astype(float).fillna(0.0),
    )
    solves = pd.concat([solved, _failed_first_solves(records)], ignore_index=True)
    fallback = time_limit if time_limit is not None else _longest(solves["time"])
    solves["limit"] = solves["time_limit"].astype(float).fillna(fallback)
    finished = solves["outcome"].isin(FINISHED)
    # An unsolved solve that overran its limit (a backend that checks its clock rarely, or a build before it)
    # is charged what it took: at the limit it would look faster than every solver that finished.
    limit = solves["limit"]
    solves["charged_solve"] = solves["solve_time"].where(finished, np.fmax(solves["solve_time"], limit))
    solves["charged"] = solves["time"].where(finished, np.fmax(solves["time"], limit))
    solves["instance"] = solves.groupby(list(INSTANCE_COLUMNS), dropna=False, sort=True).ngroup()
    return solves


def comparisons(solves: pd.DataFrame) -> list[Comparison]:
    """The exact solvers on proved optima, and every solver on optimal or completed (heuristic) solves.

    A solver is a heuristic when some solve of it ended ``completed`` (ran to its end without a proof).
    The first comparison is left out when the run has fewer than two exact solvers.
    """
    solvers = tuple(sorted(solves["solver"].unique()))
    exact = tuple(sorted(exact_solvers(solves["solver"], solves["outcome"])))
    found = [Comparison("every solver", solvers, frozenset(FINISHED))]
    if len(exact) >= 2 and len(exact) < len(solvers):
        found.insert(0, Comparison("exact solvers", exact, frozenset({"optimal"})))
    return found


def common_times(solves: pd.DataFrame, solvers: Collection[str], solved: Collection[str]) -> pd.DataFrame:
    """Times of the given solvers on their common instances, NaN where a solve does not count as solved.

    Parameters
    ----------
    solves : DataFrame
        `solve_outcomes` of a run.
    solvers : collection of str
        The solvers compared; an instance is common when each of them has a solve of it.
    solved : collection of str
        Outcomes that count as solving the instance.

    Returns
    -------
    DataFrame, one row per common instance (indexed by ``instance``), one column per solver: the measured
    time (build + solve, floored at `RESOLUTION`) of solved instances, NaN for the others.
    """
    shown = solves[solves["solver"].isin(solvers)]
    times = shown["time"].clip(lower=RESOLUTION).where(shown["outcome"].isin(solved))
    table = shown.assign(value=times).pivot_table(
        index="instance", columns="solver", values="value", aggfunc="first", dropna=False
    )
    seen = shown.groupby("instance")["solver"].nunique()
    common = seen.index[seen == len(set(solvers))]
    return table.reindex(index=common, columns=sorted(solvers))


def performance_ratios(times: pd.DataFrame) -> pd.DataFrame:
    """Performance ratios ``r_ps = t_ps / min_s t_ps`` of `common_times` (inf where not solved).

    Notes
    -----
    Dolan and More, "Benchmarking optimization software with performance profiles", Math. Program. 91
    (2002), eq. (1); an instance that no solver solved has ratio inf for all.
    """
    best = times.min(axis=1, skipna=True)
    return times.div(best, axis=0).fillna(np.inf)


def performance_profile(ratios: pd.DataFrame, taus: Iterable[float] | None = None) -> pd.DataFrame:
    """Dolan-More performance profile: per solver, the fraction of instances with ratio at most tau.

    Parameters
    ----------
    ratios : DataFrame
        `performance_ratios`: one row per instance, one column per solver.
    taus : iterable of float, optional
        Where to evaluate the profile; by default 1 and every finite ratio (its steps).

    Returns
    -------
    DataFrame indexed by ``tau`` (ascending), one column per solver: ``rho_s(tau)`` in [0, 1].

    Notes
    -----
    Dolan and More (2002), eq. (2): ``rho_s(tau) = |{p : r_ps <= tau}| / n_p``. Each curve is a right-
    continuous step function; unsolved instances (ratio inf) never count, so a curve ends at the solver's
    share of solved instances.
    """
    values = ratios.to_numpy(dtype=float)
    if taus is None:
        taus = np.unique(np.r_[1.0, values[np.isfinite(values)]])
    grid = np.asarray(list(taus), dtype=float)
    fractions = (values[None, :, :] <= grid[:, None, None]).mean(axis=1)
    return pd.DataFrame(fractions, index=pd.Index(grid, name="tau"), columns=ratios.columns)


def wins(ratios: pd.DataFrame, tolerance: float = TIE_TOLERANCE) -> pd.Series:
    """Instances each solver solved fastest: ratio at most 1 + ``tolerance``; each of tied solvers wins."""
    return (ratios <= 1.0 + tolerance).sum(axis=0).astype(int)


def _outcome_counts(solves: pd.DataFrame) -> pd.DataFrame:
    counts = pd.crosstab(solves["solver"], solves["outcome"])
    return counts.reindex(columns=list(OUTCOMES), fill_value=0)


def outcome_table(solves: pd.DataFrame, shift: float = SHIFT) -> pd.DataFrame:
    """Per solver over all its solves: outcome counts and shifted geometric means of the charged times.

    Returns
    -------
    DataFrame with ``solver``, ``solves``, one count column per outcome (`OUTCOMES`), and the shifted
    geometric means (ms) of the solve time and of build + solve, unsolved solves charged at the limit.
    """
    counts = _outcome_counts(solves)
    grouped = solves.groupby("solver", sort=True)
    table = pd.DataFrame(
        {
            "solves": grouped.size(),
            **{outcome.replace("_", " "): counts[outcome] for outcome in OUTCOMES},
            "solve sgm (ms)": grouped["charged_solve"].agg(shifted_geometric_mean, shift=shift) * 1e3,
            "build + solve sgm (ms)": grouped["charged"].agg(shifted_geometric_mean, shift=shift) * 1e3,
        }
    )
    return table.rename_axis("solver").reset_index()


def common_table(
    solves: pd.DataFrame, shift: float = SHIFT, tolerance: float = TIE_TOLERANCE
) -> pd.DataFrame:
    """Per comparison (`comparisons`) and solver, on the common instances: solved, wins, shifted geomean.

    Returns
    -------
    DataFrame with ``compared``, ``solver``, ``instances`` (common), ``solved``, ``not solved`` (time
    limit, infeasible, error or failed cell; charged at the limit), ``wins`` (fastest among those that
    solved it, ties within ``tolerance`` each win) and ``build + solve sgm (ms)`` over the common instances.
    """
    rows = []
    for comparison in comparisons(solves):
        times = common_times(solves, comparison.solvers, comparison.solved)
        won = wins(performance_ratios(times), tolerance)
        charged = solves[solves["instance"].isin(times.index)].groupby("solver")["charged"]
        for solver in comparison.solvers:
            solved = int(times[solver].notna().sum())
            rows.append(
                {
                    "compared": comparison.title,
                    "solver": solver,
                    "instances": len(times),
                    "solved": solved,
                    "not solved": len(times) - solved,
                    "wins": int(won[solver]),
                    "build + solve sgm (ms)": (
                        shifted_geometric_mean(charged.get_group(solver), shift) * 1e3
                        if len(times)
                        else np.nan
                    ),
                }
            )
    return pd.DataFrame(rows)


def sequence_table(records: pd.DataFrame, timeout: float | None = None, shift: float = SHIFT) -> pd.DataFrame:
    """Per solver over its cells: finished and failed cells, and the shifted geomean of the sequence time.

    Parameters
    ----------
    records : DataFrame
        `harness.read_records` of a run.
    timeout : float, optional
        Seconds charged to a failed cell (`FAILED_CELLS`): the run's cell timeout.
        Without it, the longest sequence of the run is charged (inf when no cell finished).
    shift : float
        Shift of the geometric mean, seconds.

    Returns
    -------
    DataFrame with ``solver``, ``cells ok``, ``cells failed`` and ``sequence sgm (ms)``. Sequences of
    different solvers hold different expressions, so this compares whole runs of Algorithm 1, not problems.
    """
    cells = records[(records["kind"] == "cell") & records["status"].isin(("ok", *FAILED_CELLS))]
    ok = cells["status"] == "ok"
    times = cells["sequence_time"].astype(float)
    charge = timeout if timeout is not None else _longest(times[ok])
    grouped = cells.assign(charged=times.where(ok, charge), ok=ok).groupby("solver", sort=True)
    finished = grouped["ok"].sum().astype(int)
    table = pd.DataFrame(
        {
            "cells ok": finished,
            "cells failed": grouped.size() - finished,
            "sequence sgm (ms)": grouped["charged"].agg(shifted_geometric_mean, shift=shift) * 1e3,
        }
    )
    return table.rename_axis("solver").reset_index()
