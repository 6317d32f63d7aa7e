"""`harness run --preset quick --solvers all`, as CI runs it; every recorded sequence re-verified."""

from __future__ import annotations

import warnings

import pandas as pd
from click.testing import CliRunner

import harness
import packing
import reports
import rigs
import solvers
from harness.cli import cli


def test_the_quick_preset_runs_every_solver_and_its_records_pass_the_checker(tmp_path) -> None:
    result = CliRunner().invoke(
        cli, ["run", "--preset", "quick", "--solvers", "all", "--out", str(tmp_path), "-q"]
    )
    assert result.exit_code == 0, result.output
    run = harness.read_run(tmp_path)
    config = harness.RunConfig.from_dict(run["config"])
    assert run["state"] == "complete" and config.solvers == tuple(solvers.names())
    assert run["n_cells"] == len(config.rigs) * len(config.warps) * len(config.solvers)

    records = harness.read_records(tmp_path)
    cells = records[records["kind"] == "cell"]
    available = set(solvers.names(available_only=True))
    assert set(cells.loc[cells["solver"].isin(available), "status"]) == {"ok"}
    assert set(cells.loc[~cells["solver"].isin(available), "status"]) <= {"skipped"}
    for cell in cells[cells["status"] == "ok"].itertuples():
        template = rigs.resolve(cell.rig, seed=cell.rig_seed)
        expressions = records[(records["cell"] == cell.cell) & (records["kind"] == "expression")]
        solver = solvers.get(cell.solver)
        overlap = solver.capabilities.max_overlap
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", packing.MissingTargetWarning)
            packing.check(
                template,
                [
                    {"shapes": shapes, "extra_examples": extra}
                    for shapes, extra in zip(
                        expressions["shapes"], expressions["extra_examples"], strict=True
                    )
                ],
                mu=cell.mu,
                symmetry=bool(cell.symmetry),
                max_per_expression=None if pd.isna(cell.cap) else int(cell.cap),
                overlap=overlap,
            )
        assert len(expressions) == cell.n_expressions and template.n_shapes == cell.n_shapes
    assert (records.loc[records["kind"] == "transfer", "status"] == "ok").all()
    assert len(reports.agreement_counts(records))
