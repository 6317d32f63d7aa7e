"""The example third-party plugin installs as its own distribution (offline, into a fresh environment) and
is discovered by entry point."""

import shutil
import sys
from pathlib import Path

import pytest

from solvers.testing import parametrize_with_checks
from tests.plugin_distribution import OFFLINE_INSTALL, fresh_environment, run_in

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "solver_plugin"


def test_installed_example_plugin_is_listed_and_conforms(tmp_path):
    source = tmp_path / "src"
    shutil.copytree(EXAMPLE, source)
    python = fresh_environment(tmp_path / "env")
    installed = run_in(python, *OFFLINE_INSTALL, str(source), cwd=tmp_path)
    assert installed.returncode == 0, installed.stderr[-3000:]
    code = (
        "import solvers\n"
        "from solvers.testing import check_solver\n"
        "for name in ('example-first-fit', 'example-scipy-milp'):\n"
        "    assert name in solvers.names(available_only=True), solvers.names()\n"
        "    print(check_solver(solvers.get(name)))\n"
    )
    result = run_in(python, "-c", code, cwd=tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    assert "validity" in result.stdout


def _example_solvers():
    sys.path.insert(0, str(EXAMPLE))
    try:
        from example_first_fit import FirstFitSolver
        from example_scipy_milp import ScipyMilpSolver
    finally:
        sys.path.remove(str(EXAMPLE))
    return [FirstFitSolver, ScipyMilpSolver]


@parametrize_with_checks(_example_solvers())
def test_example_plugins_pass_each_check(solver, check):
    check(solver)


@pytest.mark.parametrize(("module", "most"), [("example_first_fit", 16), ("example_scipy_milp", 21)])
def test_example_plugins_are_a_screenful(module, most):
    source = (EXAMPLE / f"{module}.py").read_text()
    body = source[source.index("class ") :].strip().splitlines()
    assert len(body) <= most, f"{module}: the plugin class takes {len(body)} lines"
