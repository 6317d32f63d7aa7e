"""The paper's qualitative claims on a generated rig, printed from the records (run with -s to see them)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import harness


def _claims_module():
    path = Path(__file__).with_name("paper_claims.py")
    spec = importlib.util.spec_from_file_location("harness_paper_claims", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_greedy_vs_optimal_and_importance_claims_print_from_records(tmp_path) -> None:
    claims = _claims_module()
    config = claims.claims_config(rigs=("arkit52",))
    summary = harness.run_grid(config, tmp_path, make_executor=lambda timeout: harness.LocalExecutor(jobs=2))
    assert summary.statuses == {"ok": 4}
    records, overlap = harness.read_records(tmp_path), harness.read_overlap(tmp_path)
    lines = claims.claims(records, overlap)
    print("\n".join(lines))

    table3 = overlap[(overlap["solver_a"] == "cpsat") & (overlap["solver_b"] == "greedy")]
    assert (table3["shared"] > 0).all() and (
        table3["shared"] <= table3[["shapes_a", "shapes_b"]].min(axis=1)
    ).all()
    assert any(line.startswith("  arkit52 ") and "(" in line for line in lines)
    assert sum("optimal <= greedy at" in line for line in lines) == 1
    assert sum("importance <= none at" in line for line in lines) == 1
    for cell in records[records["kind"] == "cell"].itertuples():
        transfer = records[(records["cell"] == cell.cell) & (records["kind"] == "transfer")]
        assert set(transfer["j"]) == {min(j, cell.n_expressions) for j in config.j_values}
        assert transfer["rms"].notna().all()
