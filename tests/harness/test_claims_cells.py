"""The cells the claims need: variations off the grid, and the training expressions (``--examples``)."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from click.testing import CliRunner

import harness
from harness._cell import run_cell
from harness._grid import CLAIM_TRANSFERS, CLAIM_VARIATIONS, EXAMPLES
from harness.cli import cli


def config(**fields) -> harness.RunConfig:
    base = {
        "rigs": ("tiny",),
        "warps": ("big-eyes+character",),
        "solvers": ("greedy", "cpsat", "highs"),
        "transfers": ("ebfr", "plbs", "dt", "delta"),
        "j_values": (2,),
    }
    return harness.RunConfig(**{**base, **fields})


def settings(cells) -> list[tuple]:
    return [(c.solver, c.importance, c.alpha, c.symmetry, c.distortion, c.transfers) for c in cells]


def test_variations_change_one_setting_and_run_with_the_claim_solvers_and_transfers():
    cells = config(variations=CLAIM_VARIATIONS).cells()
    grid, varied = cells[:3], cells[3:]
    assert settings(grid) == [
        (s, True, 0.5, True, "paper", ("ebfr", "plbs", "dt", "delta")) for s in ("greedy", "cpsat", "highs")
    ]
    transfers = tuple(name for name in ("ebfr", "plbs", "dt", "delta") if name in CLAIM_TRANSFERS)
    assert settings(varied) == [
        (solver, importance, alpha, symmetry, distortion, transfers)
        for importance, alpha, symmetry, distortion in (
            (False, 0.5, True, "paper"),
            (True, 0.0, True, "paper"),
            (True, 1.0, True, "paper"),
            (True, 0.5, False, "paper"),
            (True, 0.5, True, "excess"),
        )
        for solver in ("greedy", "cpsat")
    ]
    assert len({cell.id for cell in cells}) == len(cells)


def test_a_variation_on_a_grid_point_adds_nothing():
    cells = config(variations=CLAIM_VARIATIONS, importance=(True, False)).cells()
    flat = [c for c in cells if not c.importance]
    assert [c.solver for c in flat] == ["greedy", "cpsat", "highs"]  # the grid's, with every transfer
    assert all(c.transfers == ("ebfr", "plbs", "dt", "delta") for c in flat)


def test_variations_need_their_solvers_in_the_run():
    assert len(config(solvers=("highs",), variations=CLAIM_VARIATIONS).cells()) == 1
    assert [c.solver for c in config(solvers=("cpsat",), variations=CLAIM_VARIATIONS).cells()] == [
        "cpsat"
    ] * 6


def test_variations_and_examples_survive_run_json():
    stored = config(variations=CLAIM_VARIATIONS, examples=("ideal",))
    data = json.loads(json.dumps(stored.to_dict()))
    assert data["variations"][0] == [["importance", False]] and data["examples"] == ["ideal"]
    again = harness.RunConfig.from_dict(data)
    assert again == stored and [c.id for c in again.cells()] == [c.id for c in stored.cells()]


def test_examples_are_an_axis_scan_by_default():
    assert config().examples == ("scan",)
    cells = config(examples=("scan", "ideal")).cells()
    assert len(cells) == 2 * len(config().cells()) and {c.examples for c in cells} == {"scan", "ideal"}


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"examples": ("photos",)}, "--examples must be among scan, ideal, random, got \\('photos',\\)"),
        ({"examples": "scan"}, "--examples must be among scan, ideal, random, got 'scan'"),
        ({"variations": ((("jmax", 3),),)}, "changes jmax; a variation may change mu, alpha"),
        ({"variations": ((("alpha",),),)}, "a variation must be \\(field, value\\) pairs"),
    ],
)
def test_bad_grid_fields_are_one_line_errors(fields, message):
    with pytest.raises(ValueError, match=message):
        config(**fields)


def test_the_examples_are_part_of_the_cell_id_and_a_records_column():
    scan, ideal, random = (config(examples=(mode,)).cells()[0] for mode in EXAMPLES)
    assert len({scan.id, ideal.id, random.id}) == 3
    assert scan.record_fields()["examples"] == "scan" and "examples" in harness.RECORD_COLUMNS


def _rms(spec) -> list[float]:
    rows = run_cell(spec)
    assert rows[0]["status"] == "ok", rows[0]["message"]
    return [row["rms"] for row in rows if row["kind"] == "transfer" and row["transfer"] == "ebfr"]


def test_scan_sessions_differ_by_scan_seed_and_ideal_examples_do_not():
    spec = replace(
        config(solvers=("greedy",), transfers=("ebfr",), j_values=(2, 3)).cells()[0], rig_digest=""
    )
    scan = [_rms(replace(spec, scan_seed=seed, repetition=seed)) for seed in (0, 1)]
    ideal = [_rms(replace(spec, scan_seed=seed, repetition=seed, examples="ideal")) for seed in (0, 1)]
    assert _rms(replace(spec, seed=1)) == scan[0]  # the solver's seed is not the scan's
    assert scan[0] != scan[1] and ideal[0] == ideal[1]
    assert not np.allclose(scan[0], ideal[0])
    assert _rms(spec) == scan[0]  # a session is reproducible


def test_run_options_reach_run_json_and_the_grid(tmp_path):
    out = tmp_path / "out"
    arguments = [
        "run",
        "--rigs",
        "tiny",
        "--warps",
        "character",
        "--solvers",
        "greedy,cpsat",
        "--transfers",
        "ebfr",
    ]
    result = CliRunner().invoke(
        cli,
        [
            *arguments,
            "--j-values",
            "2",
            "--examples",
            "ideal",
            "--variations",
            "claims",
            "--out",
            str(out),
            "-q",
        ],
    )
    assert result.exit_code == 0, result.output
    stored = harness.read_run(out)
    assert stored["config"]["examples"] == ["ideal"] and stored["n_cells"] == 2 + 5 * 2
    assert stored["config"]["warps"] == ["character"]
    records = harness.read_records(out)
    assert set(records.loc[records["kind"] == "cell", "status"]) == {"ok"}
    assert set(records.loc[records["kind"] == "cell", "alpha"]) == {0.0, 0.5, 1.0}


def test_the_paper_preset_has_the_claims_variations_and_none_removes_them():
    paper = harness.RunConfig(preset="paper", **harness.PRESETS["paper"])
    assert paper.variations == CLAIM_VARIATIONS and paper.warps == ("alien+character",)
    assert {"plbs", "dt", "delta"} <= set(paper.transfers) and paper.examples == ("scan",)
    result = CliRunner().invoke(cli, ["run", "--help"])
    assert (
        "--examples scan|ideal|random|both" in result.output and "--variations [claims|none]" in result.output
    )


def test_variations_none_on_the_paper_preset(tmp_path):
    out = tmp_path / "out"
    result = CliRunner().invoke(
        cli,
        [
            "run",
            "--preset",
            "paper",
            "--rigs",
            "tiny",
            "--solvers",
            "greedy",
            "--transfers",
            "dt",
            "--variations",
            "none",
            "--out",
            str(out),
            "-q",
        ],
    )
    assert result.exit_code == 0, result.output
    assert harness.read_run(out)["config"]["variations"] == [] and harness.read_run(out)["n_cells"] == 1
