"""All backends in one process; exact backends agree; time limits return incumbents, not exceptions."""

import subprocess
import sys

import numpy as np
import pytest

import solvers
from packing import Termination
from solvers.testing import check_packing, face_like_problem, hard_problem

EXACT = ["highs", "cpsat", "cbc-mip", "cbc-pulp", "scip", "naive-pulp-cbc"]
#: Paper-sized synthetic problems (Table 2: vertices N and blendshapes K of each test case).
PAPER_SIZES = {"male": (73, 7366), "toon": (65, 11680), "female": (265, 5034), "digidouble": (161, 5131)}


def _available(names):
    return [name for name in names if solvers.availability(name)]


def test_every_backend_imports_and_solves_in_one_process():
    code = """
import sys, solvers
from solvers.testing import random_problem
import highspy, ortools.sat.python.cp_model, pulp  # the libraries that clash when pinned wrongly
problem = random_problem(14, 30, seed=3, cap=6)
objectives = {name: solvers.get(name).solve(problem).objective for name in solvers.names(available_only=True)}
assert len({round(v, 9) for n, v in objectives.items() if solvers.get(n).capabilities.exact}) == 1, objectives
assert "mip" not in sys.modules, "python-mip must stay in its worker process"
print(sorted(objectives))
"""
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr[-3000:]
    assert "cbc-mip" in result.stdout and "highs" in result.stdout and "cpsat" in result.stdout


@pytest.mark.parametrize("preset", sorted(PAPER_SIZES))
def test_exact_backends_reach_the_same_optimum(preset):
    shapes, vertices = PAPER_SIZES[preset]
    problem = face_like_problem(shapes, vertices, seed=1)
    results = {
        name: solvers.get(name).solve(problem) for name in _available(EXACT) if name != "naive-pulp-cbc"
    }
    reference = results["highs"]
    for name, solution in results.items():
        assert solution.termination is Termination.OPTIMAL, (name, solution.message)
        assert solution.objective == pytest.approx(reference.objective, rel=1e-9), name
        assert solution.items == reference.items, name
        check_packing(problem, solution.items)


def test_naive_baseline_reaches_the_same_optimum():
    problem = face_like_problem(73, 7366, seed=1)
    naive = solvers.get("naive-pulp-cbc").solve(problem)
    fast = solvers.get("highs").solve(problem)
    assert naive.objective == pytest.approx(fast.objective, rel=1e-9)
    assert naive.items == fast.items
    assert naive.message.startswith(f"{problem.n_vertex_rows + sum(len(i) - 1 for i in problem.items)} rows")


@pytest.mark.parametrize("name", ["highs", "cpsat", "cbc-mip", "cbc-pulp", "scip"])
def test_time_limit_returns_incumbent_and_bound(name):
    if not solvers.availability(name):
        pytest.skip(solvers.availability(name).reason)
    problem = hard_problem(seed=5)
    solution = solvers.get(name).solve(problem, time_limit=0.05)
    assert solution.termination is Termination.TIME_LIMIT
    assert solution.status.value == "feasible"
    assert solution.items and solution.objective > 0
    check_packing(problem, solution.items)
    assert solution.bound is not None and solution.bound > solution.objective


def test_cpsat_integer_scaling_keeps_tiny_weight_differences():
    from packing import problem_from_incidence

    # Two disjoint items against one item conflicting with both: optima differ by 1e-10 only.
    incidence = np.array([[1, 0], [0, 1], [1, 1]], dtype=bool)
    for heavier_pair in (True, False):
        single = 1.0 - 1e-10 if heavier_pair else 1.0 + 1e-10
        problem = problem_from_incidence(incidence, [0.5, 0.5, single])
        solution = solvers.get("cpsat").solve(problem)
        assert solution.items == ((0, 1) if heavier_pair else (2,))


def test_bad_arguments_raise_one_clear_error():
    problem = face_like_problem(10, 100)
    with pytest.raises(ValueError, match="time_limit must be positive"):
        solvers.get("highs").solve(problem, time_limit=0)
    with pytest.raises(ValueError, match=r"seed must be an integer in \[0, 2147483647\]"):
        solvers.get("cpsat").solve(problem, seed=2**40)
    with pytest.raises(TypeError, match="problem must be a packing.PackingProblem"):
        solvers.get("greedy").solve(problem.incidence)


def test_highs_runs_under_the_options_it_records_and_fails_loudly_on_a_refused_one():
    highspy = pytest.importorskip("highspy")
    from solvers._highs_model import configured_highs

    highs = configured_highs(highspy, 2.5, 7, mip_abs_gap=0.0, mip_allow_restart=False)
    recorded = {"mip_allow_restart": False, "time_limit": 2.5, "random_seed": 7, "threads": 1}
    for option, value in recorded.items():
        assert highs.getOptionValue(option)[1] == value
    with pytest.raises(RuntimeError, match="refused the option mip_rel_gap=-1.0"):
        configured_highs(highspy, None, 0, mip_rel_gap=-1.0)
    with pytest.raises(RuntimeError, match="refused the option no_such_option"):
        configured_highs(highspy, None, 0, no_such_option=True)
