"""Start-up of the ``harness`` command: ``harness --help`` and ``harness list`` <= 0.3 s for the
whole process. ``--help`` lists the built-in commands from their summaries without importing them; the
summaries are checked here against the commands themselves. Targets are checked on the best of a few runs of
the installed project (bytecode compiled, see ``conftest.compiled_project``; see ``conftest.speed_target``).
Run with ``pytest tests/benchmarks/test_bench_cli.py --benchmark-enable``.
"""

from __future__ import annotations

import subprocess
import sys

import click
import pytest

from harness.cli import BUILTIN, cli
from tests.benchmarks.timing import best_time

TARGET_SECONDS = 0.3
RUNS = 3


def _run(*arguments: str) -> tuple[float, subprocess.CompletedProcess]:
    """Fewest seconds of ``RUNS`` fresh ``harness`` processes, and the last one."""
    command = [sys.executable, "-c", "from harness.cli import main; main()", *arguments]
    return best_time(lambda: subprocess.run(command, capture_output=True, text=True, check=True), RUNS)


@pytest.mark.parametrize("arguments", [("--help",), ("list", "--json")], ids=["help", "list"])
def test_bench_cli_start(benchmark, speed_target, compiled_project, arguments):
    seconds, done = _run(*arguments)
    benchmark.pedantic(
        subprocess.run,
        args=([sys.executable, "-c", "from harness.cli import main; main()", *arguments],),
        kwargs={"capture_output": True, "check": True},
        rounds=1,
        iterations=1,
    )
    assert done.stdout
    benchmark.extra_info.update(command=" ".join(["harness", *arguments]), seconds=round(seconds, 4))
    speed_target(f"harness {' '.join(arguments)} [s]", seconds, TARGET_SECONDS)


@pytest.mark.parametrize("name", sorted(BUILTIN))
def test_help_summaries_are_the_commands_own(name):
    command = cli.get_command(click.Context(cli), name)
    for limit in (20, 45, 60, 80, 104, 200):
        assert BUILTIN[name].short_help(limit) == command.get_short_help_str(limit)
