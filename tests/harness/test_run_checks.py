"""The harness checks every sequence itself: with its own symmetry pairs and the overlap a solver declares
in ``capabilities.max_overlap``, rejecting a bound below the objective and a solver that stops with room
left. Whatever a plugin claims beyond its declared capabilities is not believed."""

from __future__ import annotations

import importlib
import sys
import textwrap
from collections.abc import Iterator
from pathlib import Path

import pytest

import harness
import solvers
from harness._grid import RunConfig
from tests.plugin_distribution import write_distribution

CHEATS = '''
"""Solver plugins that claim more than they deliver."""

from dataclasses import replace

import solvers
from packing import Termination
from solvers.greedy import GreedyOverlapSolver, GreedySolver


class EverythingSolver(GreedySolver):
    """Declares strict packing, has an ``overlap`` attribute to mislead, and returns every item at once."""

    name = "everything"
    overlap = 0.9
    capabilities = solvers.Capabilities(exact=False, time_limit=False)

    def solve(self, problem, *, time_limit=None, seed=0):
        solution = super().solve(problem, time_limit=time_limit, seed=seed)
        return replace(solution, items=tuple(range(problem.n_items)))


class WideSolver(EverythingSolver):
    """Declares 5% overlap and returns every item at once."""

    name = "wide"
    capabilities = solvers.Capabilities(exact=False, time_limit=False, max_overlap=0.05)


class Overlap30Solver(GreedyOverlapSolver):
    """Algorithm 2 with 30% overlap, declared."""

    name = "overlap30"

    def __init__(self):
        super().__init__(overlap=0.3)


class BluffSolver(GreedySolver):
    """Greedy's items, claimed optimal with a bound of 0."""

    name = "bluff"

    def solve(self, problem, *, time_limit=None, seed=0):
        solution = super().solve(problem, time_limit=time_limit, seed=seed)
        return replace(solution, termination=Termination.OPTIMAL, bound=0.0)


class IdleSolver(GreedySolver):
    """Runs to its end and chooses nothing."""

    name = "idle"

    def solve(self, problem, *, time_limit=None, seed=0):
        solution = super().solve(problem, time_limit=time_limit, seed=seed)
        return replace(solution, items=())
'''

NAMES = {
    "everything": "EverythingSolver",
    "wide": "WideSolver",
    "overlap30": "Overlap30Solver",
    "bluff": "BluffSolver",
    "idle": "IdleSolver",
}


@pytest.fixture
def cheats(tmp_path) -> Iterator[None]:
    """The cheating solver plugins, registered in this process (cells run inline)."""
    (tmp_path / "harness_cheat_plugins.py").write_text(textwrap.dedent(CHEATS))
    lines = [f"{name} = harness_cheat_plugins:{cls}" for name, cls in NAMES.items()]
    write_distribution(tmp_path, "harness_cheat_plugins", "[harness.solvers]\n" + "\n".join(lines) + "\n")
    sys.path.insert(0, str(tmp_path))
    importlib.invalidate_caches()
    solvers.refresh()
    yield
    sys.path.remove(str(tmp_path))
    importlib.invalidate_caches()
    solvers.refresh()


def test_each_claim_beyond_the_declared_capabilities_is_recorded_invalid(
    rig_file: Path, tmp_path, cheats, inline
) -> None:
    config = RunConfig(
        rigs=(str(rig_file),),
        warps=("none",),
        solvers=("greedy", *NAMES),
        transfers=("ebfr",),
        j_values=(2,),
    )
    summary = harness.run_grid(config, tmp_path / "out", make_executor=inline)
    assert summary.statuses == {"ok": 2, "invalid": 4}
    records = harness.read_records(tmp_path / "out")
    cells = records[records["kind"] == "cell"].set_index("solver")
    assert set(cells.index[cells["status"] == "ok"]) == {"greedy", "overlap30"}
    message = cells["message"]
    assert message["everything"].startswith("CheckError: expression 1: ") and "share" in message["everything"]
    assert "within overlap=0.05 of its active vertices" in message["wide"]
    assert "bound 0.0 is below its objective" in message["bluff"]
    assert message["idle"].endswith("is unused and still fits beside nothing")
    invalid = cells.index[cells["status"] == "invalid"]
    assert not records[records["solver"].isin(invalid) & (records["kind"] != "cell")].size
