"""The figures Carrigan et al. 2020 published, shown beside ours in reports (Tables 2 and 3)."""

from __future__ import annotations

import pandas as pd

#: Table 2: rig sizes and seconds for the first reference expression, optimal (PuLP + CPLEX) and greedy.
PAPER_TIMINGS = pd.DataFrame(
    [
        ("male", 7366, 73, 4.97, 0.29),
        ("toon", 11680, 65, 7.14, 0.39),
        ("female", 5034, 265, 13.14, 0.39),
        ("digidouble", 5131, 161, 13.14, 0.39),
    ],
    columns=["rig", "N", "K", "optimal_s", "greedy_s"],
).set_index("rig")

#: Table 3: blendshapes chosen by greedy / optimal in the first 5, 10, 20 expressions, and how many by both.
PAPER_AGREEMENT = pd.DataFrame(
    [
        ("male", 5, 36, 38, 31),
        ("male", 10, 49, 49, 42),
        ("male", 20, 63, 63, 56),
        ("toon", 5, 34, 33, 22),
        ("toon", 10, 48, 49, 43),
        ("toon", 20, 62, 62, 61),
        ("female", 5, 58, 54, 34),
        ("female", 10, 89, 85, 57),
        ("female", 20, 124, 116, 93),
        ("digidouble", 5, 61, 54, 39),
        ("digidouble", 10, 90, 79, 55),
        ("digidouble", 20, 126, 121, 104),
    ],
    columns=["rig", "expressions", "greedy", "optimal", "shared"],
).set_index(["rig", "expressions"])
