"""Fig. 10 of Wagner et al. 2024 from records (`reports._animation`): intervals over seeds, paired tests."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from reports._animation import (
    ALM,
    ANACONDAR,
    RANDOM,
    animation_figure,
    error_table,
    paired_table,
    shown_errors,
)

#: frames_l2 per (examples, solver, transfer): one value per seed.
VALUES = {
    ("random", "cpsat", ANACONDAR): [1.0, 2.0, 3.0],
    ("random", "greedy", ANACONDAR): [1.0, 2.0, 3.0],
    ("random", "cpsat", ALM): [2.0, 3.1, 4.2],
    ("random", "greedy", ALM): [2.0, 3.1, 4.2],
    ("ideal", "cpsat", ANACONDAR): [0.5, 2.5, 2.0],
}


def records() -> pd.DataFrame:
    rows = [
        {
            "kind": "transfer",
            "status": "ok",
            "rig": "female",
            "warp": "alien+character",
            "rig_seed": seed,
            "examples": examples,
            "solver": solver,
            "transfer": transfer,
            "j": 5,
            "frames_l2": value,
        }
        for (examples, solver, transfer), values in VALUES.items()
        for seed, value in enumerate(values)
    ]
    return pd.DataFrame(rows)


def test_random_examples_count_once_and_intervals_are_over_seeds():
    table = error_table(records()).set_index(["choice", "transfer"])
    assert sorted(table.index) == sorted([("cpsat", ANACONDAR), (RANDOM, ALM), (RANDOM, ANACONDAR)])
    row = table.loc[(RANDOM, ANACONDAR)]
    half = stats.t.ppf(0.975, 2) * 1.0 / np.sqrt(3)
    assert row["mean"] == 2.0 and row["seeds"] == 3 and row["high"] == pytest.approx(2.0 + half)
    assert "2 [" in shown_errors(records()).set_index("choice").loc[RANDOM].iloc[-1]["J=5"]


def test_a_paired_difference_decides_only_when_its_interval_excludes_zero():
    (fig10,) = paired_table(records(), (RANDOM, ANACONDAR), (RANDOM, ALM)).itertuples()
    assert fig10.verdict == "first lower" and fig10.difference == pytest.approx(-1.1)
    (packing,) = paired_table(records(), ("cpsat", ANACONDAR), (RANDOM, ANACONDAR)).itertuples()
    assert packing.verdict == "unclear"
    assert paired_table(records(), ("greedy", ANACONDAR), (RANDOM, ANACONDAR)).empty


def test_the_figure_has_a_fig10_row_and_one_per_packed_transfer():
    figure = animation_figure(records())
    assert len(figure.axes) == 2
    with pytest.raises(ValueError, match="frames_l2"):
        animation_figure(records().assign(frames_l2=np.nan))


def test_harness_show_prints_the_errors_beside_the_claims():
    from reports._terminal import _frames_table

    table = _frames_table(records())
    assert table.row_count == 3 and [column.header for column in table.columns][-1] == "J=5"
