"""Solver settings are declared with their types and ranges (`registry.Setting`), checked before anything
runs, shown by ``harness list``, and the built-in solvers take the ones their backends have."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

import packing
import rigs
import solvers
from harness._plugins import check_settings
from harness.cli import cli
from registry import HarnessError, Setting


@pytest.mark.parametrize(
    ("label", "message"),
    [
        ("cpsat[workers=on]", "workers must be an integer in [1, 64], got on"),
        ("cpsat[workers=99999999999999999999]", "workers must be an integer in [1, 64], got 9999"),
        ("cpsat[workers=0]", "workers must be an integer in [1, 64], got 0"),
        ("cpsat[workers=1.5]", "workers must be an integer in [1, 64], got 1.5"),
        ("cpsat[threads=2]", "cpsat has no setting 'threads' (its settings: workers)"),
        ("highs[presolve=2]", "presolve must be on or off, got 2"),
        ("highs[mip_heuristic_effort=2]", "mip_heuristic_effort must be a number in [0, 1], got 2"),
        ("greedy-overlap[overlap=1]", "overlap must be a number in [0, 1), got 1"),
        ("cbc-pulp[cbc=gurobi]", "cbc must be one of auto, cbcbox, bundled, got gurobi"),
    ],
)
def test_a_setting_out_of_its_declaration_is_refused_before_anything_runs(label: str, message: str) -> None:
    with pytest.raises(HarnessError) as refused:
        check_settings([label], [])
    assert str(refused.value) == f"--solvers {label}: {message}" or message in str(refused.value)
    assert "\n" not in str(refused.value)


def test_the_readmes_highs_presolve_off_solves_to_the_same_optimum() -> None:
    check_settings(["highs[presolve=off]", "highs[mip_heuristic_effort=0.2]", "cpsat[workers=2]"], [])
    problem = packing.build_problem(rigs.generate("tiny"))
    plain = solvers.get("highs").solve(problem)
    for solver in (solvers.get("highs", presolve=False), solvers.get("highs", mip_heuristic_effort=0.2)):
        answer = solver.solve(problem)
        assert answer.items == plain.items and answer.termination == packing.Termination.OPTIMAL


def test_harness_list_shows_each_solvers_settings() -> None:
    ran = CliRunner().invoke(cli, ["list", "--json"])
    assert ran.exit_code == 0, ran.output
    listed = {item["name"]: item["settings"] for item in json.loads(ran.output)["solvers"]}
    assert listed["cpsat"] == [
        {
            "name": "workers",
            "type": "int",
            "default": 1,
            "domain": "an integer in [1, 64]",
            "help": "CP-SAT search workers (1 is deterministic for a seed)",
        }
    ]
    assert [setting["name"] for setting in listed["highs"]] == ["presolve", "mip_heuristic_effort"]
    assert listed["greedy"] == []


def test_a_declaration_judges_types_and_ranges() -> None:
    workers = Setting("workers", int, 1, "workers", low=1, high=4)
    assert workers.checked(3) == 3 and Setting("f", float, 0.5, "f", low=0, high=1).checked(1) == 1.0
    for value in (True, 0, 5, 2.0, "two", float("nan")):
        with pytest.raises(ValueError, match="workers must be an integer in"):
            workers.checked(value)
    assert Setting("mode", str, "a", "mode", choices=("a", "off")).checked(False) == "off"
    with pytest.raises(TypeError):
        Setting("x", list, [], "x")
