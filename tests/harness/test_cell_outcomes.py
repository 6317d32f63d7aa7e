"""Every cell ends as a result the records name: a false infeasible verdict is ``invalid``."""

from __future__ import annotations

from pathlib import Path

import pytest

import harness
from harness._grid import RunConfig
from tests.plugin_distribution import registered_module

_ENTRY_POINTS = """[harness.solvers]
liar-infeasible = liar_solvers:InfeasibleLiar
"""


@pytest.fixture
def liar_plugins(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """Register the liars for this process and the harness's workers."""
    yield from registered_module(
        Path(__file__).with_name("liar_solvers.py"), _ENTRY_POINTS, tmp_path / "site", monkeypatch
    )


def test_an_infeasible_verdict_with_nothing_chosen_is_invalid(
    liar_plugins, rig_file, tmp_path, inline
) -> None:
    solvers = ("liar-infeasible", "greedy")
    config = RunConfig(rigs=(str(rig_file),), warps=("none",), solvers=solvers, transfers=())
    summary = harness.run_grid(config, tmp_path / "out", make_executor=inline)
    cells = harness.read_records(tmp_path / "out").query("kind == 'cell'").set_index("solver")
    assert summary.statuses == {"invalid": 1, "ok": 1}
    assert cells.loc["liar-infeasible", "status"] == "invalid"
    assert "expression 1: the solver answered infeasible" in cells.loc["liar-infeasible", "message"]
