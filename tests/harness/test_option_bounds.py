"""Every number a run takes is bounded when it is parsed (and again in a `RunConfig`), so a huge value is
one line naming the option instead of a MemoryError, a hang or an overflow after the cells ran."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from harness._bounds import check_bounds
from harness._grid import RunConfig
from harness.cli import cli
from registry import HarnessError

HUGE = str(10**12)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (["--seeds", "0-"], "'0-' is not a seed or a range of seeds"),
        (["--seeds", "-3"], "'-3' is not a seed or a range of seeds"),
        (["--permutations", HUGE], "--permutations"),
        (["--repetitions", HUGE], "--repetitions"),
        (["--jobs", HUGE], "--jobs"),
        (["--jmax", str(10**30)], "--jmax"),
        (["--j-values", f"2,{10**30}"], "--j-values"),
        (["--cap", str(10**21)], "--cap"),
        (["--scan-seed", str(2**63)], "--scan-seed"),
        (["--scan-seed", "1e30"], "--scan-seed"),
        (["--seeds", "0-9999", "--repetitions", "1000"], "the grid has 10,000,000 cells"),
    ],
)
def test_a_number_past_its_bound_is_refused_when_it_is_parsed(tmp_path, options, message) -> None:
    arguments = [
        "run",
        "--rigs",
        "tiny",
        "--warps",
        "none",
        "--solvers",
        "greedy",
        "--out",
        str(tmp_path / "o"),
    ]
    ran = CliRunner().invoke(cli, [*arguments, *options])
    assert ran.exit_code == 2 and message in ran.output, ran.output
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"repetitions": 10**12}, "--repetitions must be an integer from 0 to 1000"),
        ({"permutations": 10**12}, "--permutations must be an integer from 0 to 1000"),
        ({"jmax": 10**30}, "--jmax must be an integer from 0 to 100000"),
        ({"scan_seed": 2**63}, "--scan-seed must be an integer from 0 to 2147483647"),
        ({"seed": (2**64,)}, "--seeds must be an integer from 0 to"),
    ],
)
def test_a_configuration_past_its_bounds_is_refused_before_any_cell(change, message) -> None:
    config = RunConfig(rigs=("tiny",), warps=("none",), solvers=("greedy",), transfers=(), **change)
    with pytest.raises(HarnessError, match=message):
        check_bounds(config)
