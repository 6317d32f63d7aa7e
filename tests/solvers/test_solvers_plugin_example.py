"""The example third-party plugin installs as its own distribution and is discovered by entry point."""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from solvers.testing import parametrize_with_checks

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "solver_plugin"


@pytest.mark.network  # pip fetches the example's build backend (setuptools) into an isolated build env
def test_installed_example_plugin_is_listed_and_conforms(tmp_path):
    source = tmp_path / "src"
    shutil.copytree(EXAMPLE, source)
    target = tmp_path / "site"
    installed = subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "--quiet",
            "--no-deps",
            "--target",
            str(target),
            str(source),
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    if installed.returncode != 0:
        if "No matching distribution" in installed.stderr or "connection" in installed.stderr.lower():
            pytest.skip(f"the package index is out of reach: {installed.stderr.strip().splitlines()[-1]}")
        pytest.fail(installed.stderr)
    code = (
        "import solvers\n"
        "from solvers.testing import check_solver\n"
        "for name in ('example-first-fit', 'example-scipy-milp'):\n"
        "    assert name in solvers.names(available_only=True), solvers.names()\n"
        "    print(check_solver(solvers.get(name)))\n"
    )
    env = {"PYTHONPATH": str(target), "PATH": "/usr/bin:/bin"}
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300
    )
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
