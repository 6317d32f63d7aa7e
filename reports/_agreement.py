"""Agreement of solvers: the shapes two solvers share in their first expressions (Carrigan et al. 2020,
Table 3, which calls it overlap), computed from a run's records.

Columns of `agreement_counts`:

============== ======== ============================================================================
column         dtype    meaning
============== ======== ============================================================================
rig ... rep.   as cells the group: every cell column of `harness.GROUP_COLUMNS` (grid point minus solver)
solver_a       string   first solver of the pair (alphabetically smaller)
solver_b       string   second solver
first          int64    number of leading expressions compared (5, 10, 20)
expressions_a  int64    expressions solver_a actually has among them (<= first)
expressions_b  int64    the same for solver_b
shapes_a       int64    distinct primary shapes in solver_a's first expressions
shapes_b       int64    the same for solver_b
shared         int64    shapes in both
============== ======== ============================================================================

Only cells with status ``ok`` take part. The paper prints ``shapes_a/shapes_b (shared)``.
"""

from __future__ import annotations

import itertools

import pandas as pd

from harness import GROUP_COLUMNS

#: Leading expression counts compared, as in the paper's Table 3.
FIRST_COUNTS: tuple[int, ...] = (5, 10, 20)

#: The columns of `agreement_counts`.
AGREEMENT_COLUMNS: tuple[str, ...] = (
    *GROUP_COLUMNS,
    "solver_a",
    "solver_b",
    "first",
    "expressions_a",
    "expressions_b",
    "shapes_a",
    "shapes_b",
    "shared",
)


def agreement_counts(records: pd.DataFrame, first_counts: tuple[int, ...] = FIRST_COUNTS) -> pd.DataFrame:
    """Table 3 for every pair of solvers that ran the same grid point.

    Parameters
    ----------
    records : DataFrame
        A run's records (`harness.read_records`).
    first_counts : tuple of int
        Leading expression counts to compare.

    Returns
    -------
    DataFrame with `AGREEMENT_COLUMNS`, one row per (group, solver pair, first count).
    """
    ok_cells = records.loc[(records["kind"] == "cell") & (records["status"] == "ok"), "cell"]
    expressions = records[(records["kind"] == "expression") & records["cell"].isin(ok_cells)]
    rows = []
    for group, frame in expressions.groupby(list(GROUP_COLUMNS), dropna=False, sort=True):
        sequences = {
            solver: list(part.sort_values("expression")["shapes"])
            for solver, part in frame.groupby("solver", sort=True)
        }
        for (solver_a, seq_a), (solver_b, seq_b) in itertools.combinations(sequences.items(), 2):
            for first in first_counts:
                shapes_a = {name for shapes in seq_a[:first] for name in shapes}
                shapes_b = {name for shapes in seq_b[:first] for name in shapes}
                rows.append(
                    (
                        *group,
                        solver_a,
                        solver_b,
                        first,
                        min(first, len(seq_a)),
                        min(first, len(seq_b)),
                        len(shapes_a),
                        len(shapes_b),
                        len(shapes_a & shapes_b),
                    )
                )
    table = pd.DataFrame(rows, columns=list(AGREEMENT_COLUMNS))
    integers = ["first", "expressions_a", "expressions_b", "shapes_a", "shapes_b", "shared"]
    return table.astype({column: "int64" for column in integers})
