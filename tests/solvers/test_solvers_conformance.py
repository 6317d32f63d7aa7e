"""Every built-in solver plugin passes the public conformance suite (solvers.testing.check_solver)."""

import pytest

import solvers
from solvers.greedy import GreedyOverlapSolver
from solvers.testing import check_solver

BUILT_IN = [
    "cbc-mip",
    "cbc-pulp",
    "cpsat",
    "greedy",
    "greedy-overlap",
    "greedy-swap",
    "highs",
    "naive-pulp-cbc",
    "scip",
]


@pytest.mark.parametrize("name", BUILT_IN)
def test_built_in_solver_passes_conformance(name):
    found = solvers.availability(name)
    if not found:
        pytest.skip(f"{name} unavailable here: {found.reason}")
    ran = check_solver(solvers.get(name))
    expected = {"validity", "determinism", "bad arguments"}
    if solvers.get(name).capabilities.exact:
        expected |= {"brute-force optimum", "time limit"}
    assert expected <= set(ran)


@pytest.mark.parametrize("overlap", [0.0, 0.25, 0.5])
def test_greedy_overlap_passes_conformance_at_each_fraction(overlap):
    assert "validity" in check_solver(GreedyOverlapSolver(overlap))


def test_check_solver_catches_a_wrong_objective():
    class Liar(solvers.get("greedy").__class__):
        name = "greedy"

        def solve(self, problem, *, time_limit=None, seed=0):
            import dataclasses

            solution = super().solve(problem, time_limit=time_limit, seed=seed)
            return dataclasses.replace(solution, objective=solution.objective + 1.0)

    with pytest.raises(AssertionError, match="is not the items' importance sum"):
        check_solver(Liar)


def test_check_solver_catches_an_overlapping_packing():
    class Overlapping(solvers.get("greedy").__class__):
        def solve(self, problem, *, time_limit=None, seed=0):
            import dataclasses

            everything = tuple(range(problem.n_items))
            solution = super().solve(problem, time_limit=time_limit, seed=seed)
            return dataclasses.replace(
                solution,
                items=everything,
                shapes=problem.shapes_of(everything),
                objective=problem.objective(everything),
            )

    with pytest.raises(AssertionError, match="invalid expression"):
        check_solver(Overlapping)


def test_check_solver_catches_a_suboptimal_exact_solver():
    class NotExact(solvers.get("greedy").__class__):
        capabilities = solvers.Capabilities(exact=True, time_limit=False)

    with pytest.raises(AssertionError, match="brute-force optimum|exact solver ended"):
        check_solver(NotExact)
