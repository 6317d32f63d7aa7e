"""Fixtures of the harness tests: a small rig file, test solver plugins, an in-process executor."""

from __future__ import annotations

import contextlib
import importlib
import os
import signal
import subprocess
import sys
import textwrap
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

import rigs
import solvers
from harness._cell import run_cell
from tests.plugin_distribution import write_distribution
from transfer._registry import TRANSFERS

PLUGIN_MODULE = '''
"""Plugins for the harness tests: three solvers that sleep, one that raises, one that is unavailable, and
a transfer method that sleeps."""

import os
import time
from dataclasses import dataclass
from pathlib import Path

import solvers
from solvers.greedy import GreedySolver
from transfer.delta import DeltaTransfer


@dataclass(frozen=True)
class SluggishTransfer(DeltaTransfer):
    """The template's deltas, after sleeping HARNESS_TEST_TRANSFER_SLEEP seconds (default 60)."""

    name = "sluggish"

    def transfer(self, inputs):
        time.sleep(float(os.environ.get("HARNESS_TEST_TRANSFER_SLEEP", "60")))
        return super().transfer(inputs)


class SleepySolver(GreedySolver):
    """Greedy, after sleeping HARNESS_TEST_SLEEP seconds on the test sheet rig (not on warm-up problems)."""

    name = "sleepy"
    capabilities = solvers.Capabilities(exact=False, time_limit=False)

    def solve(self, problem, *, time_limit=None, seed=0):
        if "bump0_L" in problem.shape_names:
            time.sleep(float(os.environ.get("HARNESS_TEST_SLEEP", "60")))
        return super().solve(problem, time_limit=time_limit, seed=seed)


class StallerSolver(GreedySolver):
    """Greedy, which answers the first 2 expressions of the test sheet at once, then sleeps
    HARNESS_TEST_STALL seconds (default 60) before each later one."""

    name = "staller"
    capabilities = solvers.Capabilities(exact=False, time_limit=False)

    def solve(self, problem, *, time_limit=None, seed=0):
        if "bump0_L" in problem.shape_names and problem.meta.get("expression", 0) > 2:
            time.sleep(float(os.environ.get("HARNESS_TEST_STALL", "60")))
        return super().solve(problem, time_limit=time_limit, seed=seed)


class NapperSolver(GreedySolver):
    """Greedy. On the first expression of the test sheet it first leaves a file named by its process id in
    HARNESS_FAULT_MARKS (so that a test knows which process runs the cell), then sleeps
    HARNESS_FAULT_SLEEP seconds (default 0)."""

    name = "napper"
    capabilities = solvers.Capabilities(exact=False, time_limit=False)

    def solve(self, problem, *, time_limit=None, seed=0):
        if "bump0_L" in problem.shape_names and problem.meta.get("expression") == 1:
            marks = os.environ.get("HARNESS_FAULT_MARKS")
            if marks:
                Path(marks, str(os.getpid())).touch()
            time.sleep(float(os.environ.get("HARNESS_FAULT_SLEEP", "0")))
        return super().solve(problem, time_limit=time_limit, seed=seed)


class RaisingSolver(GreedySolver):
    name = "raising"
    capabilities = solvers.Capabilities(exact=False, time_limit=False)

    def solve(self, problem, *, time_limit=None, seed=0):
        raise RuntimeError("backend exploded on purpose")


import click
import typer


@click.command("hello")
@click.argument("who")
def hello(who):
    """Say hello (a click command added through harness.commands)."""
    click.echo(f"hello {who}")


greet = typer.Typer(help="Greetings (a typer app added through harness.commands).")


@greet.command()
def morning(who: str):
    print(f"good morning {who}")


@greet.command()
def evening(who: str):
    print(f"good evening {who}")


class MissingSolver(GreedySolver):
    name = "missing"
    capabilities = solvers.Capabilities(exact=False, time_limit=False)

    @classmethod
    def availability(cls):
        return solvers.Availability.missing_package("harness-test-nothing", "it does not exist")
'''

ENTRY_POINTS = """
[harness.solvers]
sleepy = harness_test_plugins:SleepySolver
staller = harness_test_plugins:StallerSolver
napper = harness_test_plugins:NapperSolver
raising = harness_test_plugins:RaisingSolver
missing = harness_test_plugins:MissingSolver

[harness.transfers]
sluggish = harness_test_plugins:SluggishTransfer

[harness.commands]
hello = harness_test_plugins:hello
greet = harness_test_plugins:greet
broken = harness_test_plugins:no_such_thing
"""


@pytest.fixture(scope="session")
def plugin_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A directory holding an installed-looking distribution with the test solver plugins."""
    root = tmp_path_factory.mktemp("plugins")
    (root / "harness_test_plugins.py").write_text(textwrap.dedent(PLUGIN_MODULE))
    return write_distribution(root, "harness_test_plugins", ENTRY_POINTS)


@contextlib.contextmanager
def plugins_registered(plugin_dir: Path):
    """Register the test solver plugins for this process and for the worker processes it spawns."""
    sys.path.insert(0, str(plugin_dir))
    importlib.invalidate_caches()
    solvers.refresh()
    TRANSFERS.refresh()
    old = os.environ.get("PYTHONPATH")
    os.environ["PYTHONPATH"] = os.pathsep.join([str(plugin_dir), *([old] if old else [])])
    try:
        yield plugin_dir
    finally:
        sys.path.remove(str(plugin_dir))
        if old is None:
            del os.environ["PYTHONPATH"]
        else:
            os.environ["PYTHONPATH"] = old
        importlib.invalidate_caches()
        solvers.refresh()
        TRANSFERS.refresh()


@pytest.fixture
def test_plugins(plugin_dir: Path):
    """The test solver plugins (``sleepy``, ``staller``, ``napper``, ``raising``, ``missing``), registered
    for one test."""
    with plugins_registered(plugin_dir):
        yield plugin_dir


def make_rig(n: int = 16) -> rigs.Rig:
    """A small left/right symmetric bumpy sheet with 10 local shapes (5 mirror pairs around x = 0)."""
    x, y = np.meshgrid(np.linspace(-1, 1, n), np.linspace(-1, 1, n))
    neutral = np.stack([x.ravel(), y.ravel(), 0.1 * np.cos(x.ravel())], axis=1)
    corner = (np.arange(n - 1)[:, None] * n + np.arange(n - 1)[None, :]).ravel()
    triangles = np.concatenate(
        [np.stack([corner, corner + 1, corner + n], 1), np.stack([corner + 1, corner + n + 1, corner + n], 1)]
    )
    centres = [(0.5, 0.5), (0.5, -0.5), (0.3, 0.0), (0.7, 0.1), (0.45, 0.2)]
    deltas, names = [], []
    for k, (cx, cy) in enumerate(centres):
        for side, sign in (("L", 1.0), ("R", -1.0)):
            distance = np.hypot(neutral[:, 0] - sign * cx, neutral[:, 1] - cy)
            delta = np.zeros_like(neutral)
            delta[:, 2] = np.exp(-((distance / 0.22) ** 2)) * (0.3 + 0.05 * k)
            deltas.append(delta)
            names.append(f"bump{k}_{side}")
    return rigs.Rig(
        neutral, np.array(deltas), triangles, names, provenance=rigs.Provenance(source="harness test sheet")
    )


@pytest.fixture(scope="session")
def rig_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The small test rig saved as a native .npz file."""
    path = tmp_path_factory.mktemp("rig") / "sheet.npz"
    rigs.save(make_rig(), path)
    return path


class InlineExecutor:
    """Runs cells in the calling process (no timeouts): lets tests monkeypatch what a cell calls."""

    def map(self, cells):
        for spec in cells:
            yield spec, run_cell(spec)

    def close(self):
        pass


@pytest.fixture(scope="session")
def grid_arguments(rig_file: Path) -> Callable[[str], list[str]]:
    """``harness run`` arguments (but ``--out``) of a grid of 6 cells on the test rig: the solvers greedy,
    the given one and cpsat, importance on and off, two transfers, one local worker, quiet."""

    def arguments(solver: str) -> list[str]:
        return [
            "run",
            "--rigs", str(rig_file),
            "--warps", "none",
            "--solvers", f"greedy,{solver},cpsat",
            "--importance", "both",
            "--transfers", "ebfr,dt",
            "--j-values", "2,4",
            "--jobs", "1",
            "--quiet",
        ]  # fmt: skip

    return arguments


@pytest.fixture(scope="module")
def module_plugins(plugin_dir: Path):
    """The test solver plugins, registered for a whole test module."""
    with plugins_registered(plugin_dir):
        yield plugin_dir


@pytest.fixture
def inline():
    """``make_executor`` for `harness.run_grid` that runs cells in the test process."""
    return lambda timeout: InlineExecutor()


def _comparable(records):
    import harness

    frame = records.drop(columns=list(harness.TIMING_COLUMNS))
    return frame.sort_values(["cell", "kind", "expression", "transfer", "j"]).reset_index(drop=True)


@pytest.fixture
def comparable():
    """Records without the columns that change from run to run, in a canonical row order."""
    return _comparable


def _check_stopped(process: subprocess.Popen, stderr: bytes, out: Path, stop: signal.Signals) -> None:
    import harness

    if stop == signal.SIGINT:
        assert process.returncode == 130 and "interrupted" in stderr.decode()
        assert harness.read_run(out)["state"] == "interrupted"
    else:
        assert process.returncode == -signal.SIGKILL
        assert harness.read_run(out)["state"] == "running"


@pytest.fixture
def check_stopped():
    """``check_stopped(process, stderr, out, stop)``: a ``harness run`` process ended by ``stop`` (Ctrl-C or
    kill -9) has the exit status of that end and left ``run.json`` in the matching state."""
    return _check_stopped
