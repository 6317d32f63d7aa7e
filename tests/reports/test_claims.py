"""The claims table (`reports._claims`) is computed from records: constructed records decide each verdict."""

from __future__ import annotations

import hashlib
import itertools
import json
from pathlib import Path

import pandas as pd
import pytest

import harness
from harness._records import write_part
from reports._claims import HELD, NOT_HELD, NOT_MEASURED, UNSTABLE, claims_table

SHAPES = [f"s{i}" for i in range(20)]
#: Optimal and greedy sequences sharing 9 of the optimal solver's 10 shapes in the first 5 expressions.
OPTIMAL = [SHAPES[2 * i : 2 * i + 2] for i in range(10)]
GREEDY = [*OPTIMAL[:4], [SHAPES[8], SHAPES[19]], *OPTIMAL[5:9], [SHAPES[9], SHAPES[18]]]


def cell(
    solver: str,
    *,
    rig: str = "female",
    sequence: list[list[str]] = OPTIMAL,
    rms: dict[int, float] | None = None,
    importance: bool = True,
    alpha: float = 0.5,
    symmetry: bool = True,
    repetition: int = 0,
    seed: int = 0,
    distortion: str | None = None,
    examples: str | None = None,
    cap: int | None = None,
) -> list[dict]:
    """The record rows of one finished cell: its expressions and one ebfr row per J (``distortion`` None: a
    part written before the column existed)."""
    setting = {
        "rig": rig,
        "rig_seed": seed,
        "rig_digest": "",
        "warp": "alien+character",
        "solver": solver,
        "mu": 0.3,
        "alpha": alpha,
        "beta": 0.0,
        "symmetry": symmetry,
        "importance": importance,
        "cap": cap,
        "jmax": 25,
        "time_limit": 60.0,
        "repetition": repetition,
        "seed": repetition,
        "n_vertices": 100,
        "n_shapes": len(SHAPES),
        "distortion": distortion,
        "examples": examples,
    }
    setting["cell"] = hashlib.sha256(json.dumps(setting, sort_keys=True).encode()).hexdigest()[:16]
    rows = [
        {
            **setting,
            "kind": "cell",
            "status": "ok",
            "message": "",
            "n_expressions": len(sequence),
            "n_empty": 0,
        }
    ]
    covered: set[str] = set()
    for index, shapes in enumerate(sequence, start=1):
        covered.update(shapes)
        rows.append(
            {
                **setting,
                "kind": "expression",
                "status": "optimal",
                "expression": index,
                "shapes": shapes,
                "covered": len(covered),
                "coverage": len(covered) / len(SHAPES),
            }
        )
    for j, value in (rms or {}).items():
        rows.append({**setting, "kind": "transfer", "status": "ok", "transfer": "ebfr", "j": j, "rms": value})
    return rows


def table(tmp_path: Path, *cells: list[dict]) -> pd.DataFrame:
    """The claims table of a run made of ``cells`` (written as part files and read back)."""
    for rows in cells:
        write_part(tmp_path, rows[0]["cell"], rows)
    return claims_table(harness.read_records(tmp_path)).set_index("claim")


def verdict(found: pd.DataFrame, start: str) -> tuple[str, str]:
    row = found.loc[[claim for claim in found.index if claim.startswith(start)][0]]
    return row["verdict"], row["measured"]


GOOD = {2: 0.050, 4: 0.040, 7: 0.030}
WORSE = {2: 0.055, 4: 0.044, 7: 0.033}


def claim_cells(optimal_rms=GOOD, greedy_rms=WORSE, flat_rms=WORSE, alphas=None, symmetry_off=GOOD):
    alphas = alphas or {0.0: WORSE, 1.0: WORSE}
    return [
        cell("cpsat", rms=optimal_rms),
        cell("greedy", sequence=GREEDY, rms=greedy_rms),
        cell("cpsat", rms=flat_rms, importance=False),
        cell("cpsat", rms=symmetry_off, symmetry=False),
        *(cell("cpsat", rms=values, alpha=alpha) for alpha, values in alphas.items()),
    ]


def test_every_claim_held_on_records_that_show_it(tmp_path):
    found = table(tmp_path, *claim_cells())
    assert list(found.columns) == ["paper", "measured", "verdict"] and len(found) == 10
    assert verdict(found, "greedy and optimal")[0] == HELD  # 9 of 10 shapes = 90% at 5 expressions
    assert "90%" in verdict(found, "greedy and optimal")[1]
    assert verdict(found, "optimal expressions") == (
        HELD,
        "cpsat below greedy at 3 of 3 (seed, rig, warp, J) points: 100%, 95% interval 44%-100%; median "
        "difference -9.1%; one seed (0): run --seeds 0-4 to test the sign across faces",
    )
    assert verdict(found, "importance weights")[0] == HELD
    assert verdict(found, "alpha = 0.5")[0] == HELD
    assert verdict(found, "symmetry barely")[0] == HELD
    assert verdict(found, "20 expressions") == (
        NOT_HELD,
        "female/alien+character cpsat 100%, female/alien+character greedy 100%",
    )


def test_optimal_above_greedy_is_not_held(tmp_path):
    found = table(tmp_path, *claim_cells(optimal_rms=WORSE, greedy_rms=GOOD))
    held, measured = verdict(found, "optimal expressions")
    assert held == NOT_HELD and measured.startswith("cpsat below greedy at 0 of 3")


def test_importance_that_does_not_help_is_not_held(tmp_path):
    found = table(tmp_path, *claim_cells(flat_rms={2: 0.049, 4: 0.039, 7: 0.031}))
    held, measured = verdict(found, "importance weights")
    assert held == NOT_HELD and "at 1 of 3" in measured


def test_an_alpha_well_below_half_is_not_held(tmp_path):
    better = {j: 0.9 * value for j, value in GOOD.items()}
    found = table(tmp_path, *claim_cells(alphas={0.0: better, 1.0: WORSE}))
    held, measured = verdict(found, "alpha = 0.5")
    assert held == NOT_HELD and "best alpha 0, alpha 0.5 +11.1%" in measured


def test_an_alpha_just_above_the_best_is_near(tmp_path):
    slightly = {j: 0.99 * value for j, value in GOOD.items()}
    found = table(tmp_path, *claim_cells(alphas={0.0: slightly, 1.0: WORSE}))
    assert verdict(found, "alpha = 0.5")[0] == HELD


def test_symmetry_that_changes_the_error_is_not_held(tmp_path):
    found = table(tmp_path, *claim_cells(symmetry_off={2: 0.050, 4: 0.045, 7: 0.030}))
    held, measured = verdict(found, "symmetry barely")
    assert held == NOT_HELD and measured.startswith("largest change 12.5%")


def test_identical_greedy_and_optimal_shapes_are_not_held(tmp_path):
    found = table(tmp_path, cell("cpsat", rms=GOOD), cell("greedy", rms=WORSE))
    held, measured = verdict(found, "greedy and optimal")
    assert (
        held == NOT_HELD and measured == "greedy/cpsat: 100% (female 5 ex.) to 100% (female 5 ex.), 1 value"
    )


def test_shared_shapes_once_every_shape_is_used_are_no_evidence(tmp_path):
    found = table(tmp_path, cell("cpsat", sequence=OPTIMAL[:4] + [SHAPES[8:]]), cell("greedy", rms=WORSE))
    assert verdict(found, "greedy and optimal") == (
        NOT_MEASURED,
        "every compared sequence had used every shape already",
    )


def test_coverage_near_the_papers_is_held(tmp_path):
    # 14 of 20 shapes = 70% (paper: 67% for female), 18 of 20 = 90% for male (paper 86%).
    female = [OPTIMAL[i] for i in range(7)]
    male = [OPTIMAL[i] for i in range(9)]
    found = table(
        tmp_path,
        cell("cpsat", sequence=female),
        cell("greedy", sequence=female),
        cell("cpsat", rig="male", sequence=male),
    )
    assert verdict(found, "20 expressions") == (
        HELD,
        "female/alien+character cpsat 70%, female/alien+character greedy 70%, male/alien+character cpsat 90%",
    )


def test_claims_without_their_cells_are_not_measured(tmp_path):
    found = table(tmp_path, cell("highs", rms=GOOD, rig="arkit52"))
    verdicts = dict(zip(found.index, found["verdict"], strict=True))
    assert set(verdicts.values()) == {NOT_MEASURED}
    assert "--variations claims" in verdict(found, "importance weights")[1]
    assert "needs expressions of female, male or toon" == verdict(found, "20 expressions")[1]


def test_repetitions_are_summarised_by_their_median(tmp_path):
    repeated = [
        cell("cpsat", rms={2: value}, repetition=repetition)
        for repetition, value in enumerate([0.050, 0.060, 0.070])
    ]
    greedy = [cell("greedy", sequence=GREEDY, rms={2: 0.065}, repetition=r) for r in range(3)]
    found = table(tmp_path, *itertools.chain(repeated, greedy))
    assert verdict(found, "optimal expressions")[1].startswith(
        "cpsat below greedy at 1 of 1 (seed, rig, warp, J) points: 100%"
    )
    assert "median difference -7.7%" in verdict(found, "optimal expressions")[1]


@pytest.mark.parametrize("solver", ["highs", "scip"])
def test_the_first_exact_solver_of_the_run_stands_for_optimal(tmp_path, solver):
    found = table(tmp_path, cell(solver, rms=WORSE), cell("greedy", sequence=GREEDY, rms=GOOD))
    assert verdict(found, "optimal expressions")[1].startswith(f"{solver} below greedy at 0 of 3")


def seeded(optimal: dict[int, dict[int, float]], greedy: dict[int, float] = WORSE) -> list[list[dict]]:
    """An optimal and a greedy cell per seed: ``optimal[seed]`` the optimal solver's RMS per J there."""
    return [
        rows
        for seed, rms in optimal.items()
        for rows in (
            cell("cpsat", rms=rms, seed=seed),
            cell("greedy", sequence=GREEDY, rms=greedy, seed=seed),
        )
    ]


def test_a_claim_held_on_every_seed_is_held_with_its_share(tmp_path):
    found = table(tmp_path, *seeded({seed: GOOD for seed in range(4)}))
    held, measured = verdict(found, "optimal expressions")
    assert held == HELD
    assert "at 12 of 12 (seed, rig, warp, J) points: 100%, 95% interval 76%-100%" in measured
    assert "per seed 0: -9.1%, 1: -9.1%, 2: -9.1%, 3: -9.1%" in measured


def test_a_claim_whose_sign_flips_with_the_seed_is_unstable(tmp_path):
    # Seeds 0-2 show it by 9%, seed 3 the opposite: 9 of 12 points hold, but not on every face.
    found = table(tmp_path, *seeded({0: GOOD, 1: GOOD, 2: GOOD, 3: {j: 1.2 * v for j, v in WORSE.items()}}))
    held, measured = verdict(found, "optimal expressions")
    assert held == UNSTABLE and "at 9 of 12" in measured and "3: +20.0%" in measured


def test_the_excess_distortion_is_compared_with_the_papers(tmp_path):
    found = table(
        tmp_path,
        cell("cpsat", rms=WORSE),
        cell("cpsat", rms=GOOD, distortion="excess"),
        cell("greedy", sequence=GREEDY, rms=WORSE),
    )
    held, measured = verdict(found, "the excess distortion")
    assert held == HELD and measured.startswith("excess below paper at 3 of 3")


def test_scan_and_ideal_examples_are_compared_on_the_same_packings(tmp_path):
    found = table(
        tmp_path,
        cell("cpsat", rms=GOOD, examples="ideal"),
        cell("cpsat", rms=WORSE, examples="scan"),
        cell("greedy", sequence=GREEDY, rms=WORSE, examples="scan"),
    )
    held, measured = verdict(found, "scan-like examples")
    assert held == HELD and measured.startswith("ideal below scan at 3 of 3")


@pytest.mark.parametrize(("ebfr", "expected"), [(0.3, HELD), (0.5, NOT_HELD)])
def test_the_sanity_row_holds_ebfr_to_a_third_of_dt_with_exact_isolated_examples(tmp_path, ebfr, expected):
    isolated = {"sequence": [[shape] for shape in SHAPES], "symmetry": False, "cap": 1, "examples": "ideal"}
    rows = cell("greedy", rms={20: ebfr}, **isolated)
    last = rows[-1]
    rows += [
        {**last, "transfer": "dt", "rms": 1.0},
        {**last, "transfer": "ebfr[beta=0.1]", "rms": 0.05},
        {**last, "transfer": "anacondar", "rms": 0.03},
    ]
    found = table(tmp_path, rows)
    held, measured = verdict(found, "every shape scanned alone")
    assert held == expected and f"ebfr/dt {ebfr:.3f} (anacondar 0.03, beta=0.1 0.05)" in measured


def test_the_sanity_row_needs_isolated_cells(tmp_path):
    found = table(tmp_path, *claim_cells())
    assert verdict(found, "every shape scanned alone")[0] == NOT_MEASURED


def animation_cells(packed: dict[int, list[float]], random: dict[int, list[float]]) -> list[list[dict]]:
    """Cells of a fig10-like run: per seed, cpsat's packing and random examples (one cell per solver, as
    the grid makes them), each with an anacondar and an ebfr ``frames_l2`` row per J."""
    cells = []
    for seed in range(len(next(iter(packed.values())))):
        for solver, examples, values in (("cpsat", "ideal", packed), ("cpsat", "random", random)):
            rows = cell(solver, seed=seed, examples=examples)
            for j, errors in values.items():
                for transfer in ("anacondar", "ebfr"):
                    rows.append(
                        {
                            **rows[0],
                            "kind": "transfer",
                            "transfer": transfer,
                            "j": j,
                            "frames_l2": errors[seed],
                        }
                    )
            cells.append(rows)
    return cells


def test_packing_against_random_examples_is_judged_over_seeds(tmp_path):
    found = table(
        tmp_path, *animation_cells({5: [1.0, 2.0], 10: [0.5, 1.0]}, {5: [2.0, 3.0], 10: [1.0, 2.0]})
    )
    held, measured = verdict(found, "packed expressions train anacondar")
    assert held == HELD and measured.startswith("anacondar cpsat: cpsat below random at 4 of 4")
    assert "ebfr cpsat: below random at 4 of 4 points" in measured


def test_packing_against_random_examples_flips_between_seeds(tmp_path, tmp_path_factory):
    found = table(
        tmp_path, *animation_cells({5: [1.0, 4.0], 10: [0.5, 3.0]}, {5: [2.0, 3.0], 10: [1.0, 2.0]})
    )
    assert verdict(found, "packed expressions train anacondar")[0] == UNSTABLE
    other = table(tmp_path_factory.mktemp("none"), *claim_cells())
    assert verdict(other, "packed expressions train anacondar")[0] == NOT_MEASURED
