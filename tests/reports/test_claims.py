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
from reports._claims import HELD, INCONCLUSIVE, NOT_HELD, NOT_MEASURED, claims_table

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
#: Three faces: the least that gives a claim an interval with room to spare.
SEEDS = (0, 1, 2)


def claim_cells(
    optimal_rms=GOOD, greedy_rms=WORSE, flat_rms=WORSE, alphas=None, symmetry_off=GOOD, seeds=SEEDS
):
    alphas = alphas or {0.0: WORSE, 1.0: WORSE}
    return [
        rows
        for seed in seeds
        for rows in (
            cell("cpsat", rms=optimal_rms, seed=seed),
            cell("greedy", sequence=GREEDY, rms=greedy_rms, seed=seed),
            cell("cpsat", rms=flat_rms, importance=False, seed=seed),
            cell("cpsat", rms=symmetry_off, symmetry=False, seed=seed),
            *(cell("cpsat", rms=values, alpha=alpha, seed=seed) for alpha, values in alphas.items()),
        )
    ]


def test_every_claim_held_on_records_that_show_it(tmp_path):
    found = table(tmp_path, *claim_cells())
    assert list(found.columns) == ["paper", "measured", "verdict"] and len(found) == 10
    assert verdict(found, "greedy and optimal") == (  # 9 of 10 shapes = 90% at 5 expressions, every face
        HELD,
        "greedy/cpsat: mean over 3 faces 90% (95% interval 90% to 90%; claimed: 63% to 98%); per seed "
        "0: 90%, 1: 90%, 2: 90%; single values 90% to 90% of 3",
    )
    assert verdict(found, "optimal expressions") == (
        HELD,
        "cpsat against greedy: mean over 3 faces -9.1% (95% interval -9.1% to -9.1%; claimed: at most "
        "-1.0%); per seed 0: -9.1%, 1: -9.1%, 2: -9.1%; lower at 9 of 9 (seed, rig, warp, J) points",
    )
    assert verdict(found, "importance weights")[0] == HELD
    assert verdict(found, "alpha = 0.5")[0] == HELD
    assert verdict(found, "symmetry barely")[0] == HELD
    assert verdict(found, "20 expressions")[0] == NOT_HELD  # 100% covered against the paper's 67%
    assert "female cpsat 100%, female greedy 100%" in verdict(found, "20 expressions")[1]


def test_one_face_is_inconclusive_whatever_it_shows(tmp_path):
    found = table(tmp_path, *claim_cells(seeds=(0,)))
    held, measured = verdict(found, "optimal expressions")
    assert held == INCONCLUSIVE and "one face: no interval; run --seeds 0-4" in measured


def test_optimal_above_greedy_is_not_held(tmp_path):
    found = table(tmp_path, *claim_cells(optimal_rms=WORSE, greedy_rms=GOOD))
    held, measured = verdict(found, "optimal expressions")
    assert held == NOT_HELD and "mean over 3 faces +10.0%" in measured and "lower at 0 of 9" in measured


def test_importance_that_does_not_help_is_not_held(tmp_path):
    found = table(tmp_path, *claim_cells(flat_rms={2: 0.049, 4: 0.039, 7: 0.031}))
    held, measured = verdict(found, "importance weights")
    assert held == NOT_HELD and "lower at 3 of 9" in measured


def test_ties_are_no_direction(tmp_path):
    # Optimal and greedy transfer identically at every point: the claim of "lower" is not held.
    found = table(tmp_path, *claim_cells(optimal_rms=WORSE, greedy_rms=WORSE))
    held, measured = verdict(found, "optimal expressions")
    assert held == NOT_HELD and "mean over 3 faces +0.0%" in measured and "9 tied" in measured


def test_an_alpha_well_below_half_is_not_held(tmp_path):
    better = {j: 0.9 * value for j, value in GOOD.items()}
    found = table(tmp_path, *claim_cells(alphas={0.0: better, 1.0: WORSE}))
    held, measured = verdict(found, "alpha = 0.5")
    assert (
        held == NOT_HELD and "mean over 3 faces +11.1%" in measured and "best alpha 0 on 3 of 3" in measured
    )


def test_an_alpha_just_above_the_best_is_near(tmp_path):
    slightly = {j: 0.99 * value for j, value in GOOD.items()}
    found = table(tmp_path, *claim_cells(alphas={0.0: slightly, 1.0: WORSE}))
    assert verdict(found, "alpha = 0.5")[0] == HELD


def test_alpha_reads_ebfr_only(tmp_path):
    # A dt row per alpha, far better at alpha 0, must not move the ebfr claim.
    cells = claim_cells()
    for rows in cells:
        if rows[0]["alpha"] == 0.0:
            rows += [
                {**row, "transfer": "dt", "rms": row["rms"] / 10} for row in rows if row["kind"] == "transfer"
            ]
    found = table(tmp_path, *cells)
    assert verdict(found, "alpha = 0.5")[0] == HELD


def test_symmetry_that_changes_the_error_is_not_held(tmp_path):
    found = table(tmp_path, *claim_cells(symmetry_off={2: 0.055, 4: 0.045, 7: 0.033}))
    held, measured = verdict(found, "symmetry barely")
    assert held == NOT_HELD and "mean over 3 faces 10.0%" in measured and "largest 12.5%" in measured


def test_one_symmetry_outlier_among_many_points_does_not_fail_the_claim(tmp_path):
    # The claim is about the typical change of a face, not the largest of all points: adding faces with the
    # same evidence can never make it harder to pass.
    found = table(tmp_path, *claim_cells(symmetry_off={2: 0.050, 4: 0.045, 7: 0.030}))
    held, measured = verdict(found, "symmetry barely")
    assert held == HELD and "largest 12.5%" in measured


def test_identical_greedy_and_optimal_shapes_are_not_held(tmp_path):
    found = table(
        tmp_path, *(cell(solver, rms=GOOD, seed=seed) for seed in SEEDS for solver in ("cpsat", "greedy"))
    )
    held, measured = verdict(found, "greedy and optimal")
    assert held == NOT_HELD and measured.startswith("greedy/cpsat: mean over 3 faces 100%")


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
        *(
            rows
            for seed in SEEDS
            for rows in (
                cell("cpsat", sequence=female, seed=seed),
                cell("greedy", sequence=female, seed=seed),
                cell("cpsat", rig="male", sequence=male, seed=seed),
            )
        ),
    )
    held, measured = verdict(found, "20 expressions")
    assert held == HELD
    assert measured.startswith("distance to the paper's share: mean over 6 faces 3% (95% interval 3% to 4%")
    assert measured.endswith("female cpsat 70%, female greedy 70%, male cpsat 90%")


def test_coverage_off_by_the_same_amount_either_way_is_not_held(tmp_path):
    # Female 10 points above the paper, male 10 below: the mean deviation is 0, the distance is not.
    female = [OPTIMAL[i] for i in range(8)]  # 16 of 20 = 80% against 67%
    male = [OPTIMAL[i] for i in range(7)]  # 14 of 20 = 70% against 86%
    cells = [
        cell("cpsat", rig=rig, sequence=sequence, seed=seed)
        for seed in SEEDS
        for rig, sequence in (("female", female), ("male", male))
    ]
    assert verdict(table(tmp_path, *cells), "20 expressions")[0] == NOT_HELD


def test_claims_without_their_cells_are_not_measured(tmp_path):
    found = table(tmp_path, cell("highs", rms=GOOD, rig="arkit52"))
    verdicts = dict(zip(found.index, found["verdict"], strict=True))
    assert set(verdicts.values()) == {NOT_MEASURED}
    assert "--variations claims" in verdict(found, "importance weights")[1]
    assert "needs expressions of female, male or toon" == verdict(found, "20 expressions")[1]


def test_repetitions_are_summarised_by_their_median(tmp_path):
    repeated = [
        cell("cpsat", rms={2: value}, repetition=repetition, seed=seed)
        for seed in SEEDS
        for repetition, value in enumerate([0.050, 0.060, 0.070])
    ]
    greedy = [
        cell("greedy", sequence=GREEDY, rms={2: 0.065}, repetition=r, seed=s) for r in range(3) for s in SEEDS
    ]
    found = table(tmp_path, *itertools.chain(repeated, greedy))
    assert "mean over 3 faces -7.7%" in verdict(found, "optimal expressions")[1]


@pytest.mark.parametrize("solver", ["highs", "scip"])
def test_the_first_exact_solver_of_the_run_stands_for_optimal(tmp_path, solver):
    found = table(
        tmp_path,
        *(cell(solver, rms=WORSE, seed=seed) for seed in SEEDS),
        *(cell("greedy", sequence=GREEDY, rms=GOOD, seed=seed) for seed in SEEDS),
    )
    assert verdict(found, "optimal expressions")[1].startswith(f"{solver} against greedy: mean over 3 faces")


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


def test_a_claim_whose_sign_flips_with_the_seed_is_inconclusive(tmp_path):
    # Seeds 0-2 show it by 9%, seed 3 the opposite by 20%: the interval of the mean crosses -1%.
    found = table(tmp_path, *seeded({0: GOOD, 1: GOOD, 2: GOOD, 3: {j: 1.2 * v for j, v in WORSE.items()}}))
    held, measured = verdict(found, "optimal expressions")
    assert held == INCONCLUSIVE and "lower at 9 of 12" in measured and "3: +20.0%" in measured


def test_one_face_against_the_claim_among_many_is_weighed_not_vetoed(tmp_path):
    # Nine faces show it by about 9%, one the opposite by 1%: the mean's interval lies below -1%.
    faces = {seed: {j: v * (1 + 0.01 * seed / 9) for j, v in GOOD.items()} for seed in range(9)}
    faces[9] = {j: 1.01 * v for j, v in WORSE.items()}
    held, measured = verdict(table(tmp_path, *seeded(faces)), "optimal expressions")
    assert held == HELD and "9: +1.0%" in measured


def test_the_excess_distortion_is_compared_with_the_papers(tmp_path):
    found = table(
        tmp_path,
        *(
            rows
            for seed in SEEDS
            for rows in (
                cell("cpsat", rms=WORSE, seed=seed),
                cell("cpsat", rms=GOOD, distortion="excess", seed=seed),
                cell("greedy", sequence=GREEDY, rms=WORSE, seed=seed),
            )
        ),
    )
    held, measured = verdict(found, "the excess distortion")
    assert held == HELD and measured.startswith("excess against paper: mean over 3 faces -9.1%")


def test_scan_and_ideal_examples_are_compared_on_the_same_packings(tmp_path):
    found = table(
        tmp_path,
        *(
            rows
            for seed in SEEDS
            for rows in (
                cell("cpsat", rms=GOOD, examples="ideal", seed=seed),
                cell("cpsat", rms=WORSE, examples="scan", seed=seed),
                cell("greedy", sequence=GREEDY, rms=WORSE, examples="scan", seed=seed),
            )
        ),
    )
    held, measured = verdict(found, "scan-like examples")
    assert held == HELD and measured.startswith("ideal against scan: mean over 3 faces -9.1%")


@pytest.mark.parametrize(("ebfr", "expected"), [(0.3, HELD), (0.5, NOT_HELD)])
def test_the_sanity_row_holds_ebfr_to_a_third_of_dt_with_exact_isolated_examples(tmp_path, ebfr, expected):
    isolated = {"sequence": [[shape] for shape in SHAPES], "symmetry": False, "cap": 1, "examples": "ideal"}
    cells = []
    for seed in SEEDS:
        rows = cell("greedy", rms={20: ebfr}, seed=seed, **isolated)
        last = rows[-1]
        rows += [
            {**last, "transfer": "dt", "rms": 1.0},
            {**last, "transfer": "ebfr[beta=0.1]", "rms": 0.05},
            {**last, "transfer": "anacondar", "rms": 0.03},
        ]
        cells.append(rows)
    found = table(tmp_path, *cells)
    held, measured = verdict(found, "every shape scanned alone")
    assert held == expected and f"ebfr/dt {ebfr:.3f} (anacondar 0.03, beta=0.1 0.05)" in measured
    assert f"mean over 3 faces {ebfr:.3f}" in measured


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
        tmp_path,
        *animation_cells(
            {5: [1.0, 2.0, 1.5], 10: [0.5, 1.0, 0.8]}, {5: [2.0, 3.0, 2.5], 10: [1.0, 2.0, 1.5]}
        ),
    )
    held, measured = verdict(found, "packed expressions train anacondar")
    assert held == HELD and measured.startswith("anacondar cpsat against random: mean over 3 faces")
    assert "lower at 6 of 6" in measured
    assert "ebfr cpsat against random (held): mean over 3 faces" in measured


def test_packing_against_random_examples_flips_between_seeds(tmp_path, tmp_path_factory):
    found = table(
        tmp_path,
        *animation_cells(
            {5: [1.0, 4.0, 1.0], 10: [0.5, 3.0, 0.5]}, {5: [2.0, 3.0, 2.0], 10: [1.0, 2.0, 1.0]}
        ),
    )
    assert verdict(found, "packed expressions train anacondar")[0] == INCONCLUSIVE
    other = table(tmp_path_factory.mktemp("none"), *claim_cells())
    assert verdict(other, "packed expressions train anacondar")[0] == NOT_MEASURED
