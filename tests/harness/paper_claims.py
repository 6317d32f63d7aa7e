"""The paper's qualitative claims (Carrigan et al. 2020, sec. 5.2), read from the records of a run.

1. Greedy vs optimal share most of their shapes in the first 5, 10, 20 expressions (Table 3).
2. Transfer from the optimal solver's expressions is as accurate as from greedy's or better at most J
   (Fig. 10).
3. Importance weighting lowers the transfer error against no importance (Fig. 9).

Usage: ``python tests/harness/paper_claims.py [OUT]`` prints the claims of the run in OUT, or, without OUT,
runs the grid of `claims_config` first (a few minutes on 2 cores) into a temporary directory.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import pandas as pd

import harness

GREEDY, OPTIMAL = "greedy", "cpsat"


def claims_config(rigs: tuple[str, ...] = ("male", "digidouble")) -> harness.RunConfig:
    """Greedy and optimal, with and without importance, transferred with ebfr, on warped paper-sized rigs."""
    return harness.RunConfig(
        rigs=rigs,
        warps=("alien",),
        solvers=(GREEDY, OPTIMAL),
        transfers=("ebfr",),
        importance=(True, False),
        jmax=20,
        j_values=(2, 4, 7, 10, 15, 20),
        time_limit=60.0,
    )


def _rms(records: pd.DataFrame, **where: object) -> pd.Series:
    """RMS of the ebfr transfer per (rig, J) for the rows matching ``where``."""
    rows = records[
        (records["kind"] == "transfer") & (records["status"] == "ok") & (records["transfer"] == "ebfr")
    ]
    for column, value in where.items():
        rows = rows[rows[column] == value]
    return rows.groupby(["rig", "j"])["rms"].median()


def claims(records: pd.DataFrame, overlap: pd.DataFrame) -> list[str]:
    """The three claims as printable lines, one block per claim (rigs lacking the cells are skipped)."""
    lines = ["Table 3: shapes chosen by greedy/optimal (shared) in the first 5, 10, 20 expressions"]
    pairs = overlap[
        (overlap["solver_a"] == OPTIMAL) & (overlap["solver_b"] == GREEDY) & overlap["importance"]
    ]
    for rig, table in pairs.groupby("rig", sort=True):
        cells = [f"{r.shapes_b}/{r.shapes_a} ({r.shared})" for r in table.sort_values("first").itertuples()]
        lines.append(f"  {rig:<12} " + "   ".join(cells))

    lines.append("Fig. 10: ebfr RMS with optimal vs greedy expressions (importance on)")
    optimal = _rms(records, solver=OPTIMAL, importance=True)
    greedy = _rms(records, solver=GREEDY, importance=True)
    for rig in sorted(set(optimal.index.get_level_values(0)) & set(greedy.index.get_level_values(0))):
        both = pd.concat([optimal[rig], greedy[rig]], axis=1, keys=["optimal", "greedy"]).dropna()
        wins = int((both["optimal"] <= both["greedy"] * (1 + 1e-9)).sum())
        lines.append(f"  {rig:<12} optimal <= greedy at {wins} of {len(both)} J values")
        lines += [
            f"    J={j:<3} optimal {row.optimal:.5g}  greedy {row.greedy:.5g}" for j, row in both.iterrows()
        ]

    lines.append("Fig. 9: ebfr RMS with importance vs without (optimal solver)")
    weighted = _rms(records, solver=OPTIMAL, importance=True)
    flat = _rms(records, solver=OPTIMAL, importance=False)
    for rig in sorted(set(weighted.index.get_level_values(0)) & set(flat.index.get_level_values(0))):
        both = pd.concat([weighted[rig], flat[rig]], axis=1, keys=["weighted", "flat"]).dropna()
        wins = int((both["weighted"] <= both["flat"] * (1 + 1e-9)).sum())
        lines.append(f"  {rig:<12} importance <= none at {wins} of {len(both)} J values")
        lines += [
            f"    J={j:<3} importance {row.weighted:.5g}  none {row.flat:.5g}" for j, row in both.iterrows()
        ]
    return lines


def main(argv: list[str]) -> None:
    if argv:
        out = Path(argv[0])
    else:
        out = Path(tempfile.mkdtemp(prefix="paper-claims-"))
        harness.run_grid(claims_config(), out, make_executor=lambda timeout: harness.LocalExecutor(jobs=2))
    print("\n".join(claims(harness.read_records(out), harness.read_overlap(out))))


if __name__ == "__main__":
    main(sys.argv[1:])
