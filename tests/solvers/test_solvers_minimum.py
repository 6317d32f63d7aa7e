"""Minimum expression count (colouring of the conflict graph) and the ordered minimum sequence."""

import itertools

import numpy as np
import pytest

import solvers
from packing import Termination, first_fit_colouring, problem_from_incidence
from solvers.testing import check_packing, random_problem


def _chromatic_number(problem):
    """Fewest expressions by exhaustive search: a partition of all items into packings (tiny problems)."""
    n = problem.n_items
    packings = []
    for mask in range(1, 2**n):
        try:
            check_packing(problem, [i for i in range(n) if mask >> i & 1])
        except AssertionError:
            continue
        packings.append(mask)
    fewest = [0] + [n + 1] * (2**n - 1)
    for mask in range(1, 2**n):
        lowest = mask & -mask
        fewest[mask] = 1 + min(fewest[mask ^ s] for s in packings if s & lowest and s & mask == s)
    return fewest[-1]


def _assert_cover(problem, expressions):
    assert sorted(i for group in expressions for i in group) == list(range(problem.n_items))
    for group in expressions:
        check_packing(problem, group)


@pytest.mark.parametrize("backend", ["cpsat", "highs"])
@pytest.mark.parametrize("seed", range(4))
def test_minimum_matches_exhaustive_search(backend, seed):
    problem = random_problem(7, 12, seed=seed, active=(2, 5), cap=4 if seed % 2 else None)
    result = solvers.minimum_expressions(problem, solver=backend)
    assert result.termination is Termination.OPTIMAL
    assert result.count == _chromatic_number(problem)
    assert result.lower_bound <= result.count
    _assert_cover(problem, result.expressions)


def test_minimum_beats_first_fit_where_first_fit_is_poor():
    problem = random_problem(60, 70, seed=3, active=(3, 8))
    result = solvers.minimum_expressions(problem, time_limit=30)
    assert result.count <= first_fit_colouring(problem).max() + 1
    assert result.count == result.lower_bound or result.termination is Termination.TIME_LIMIT
    _assert_cover(problem, result.expressions)


def test_both_backends_agree_on_the_count():
    problem = random_problem(40, 60, seed=9, active=(3, 8), cap=6)
    counts = {
        b: solvers.minimum_expressions(problem, solver=b, time_limit=30).count for b in ("cpsat", "highs")
    }
    assert counts["cpsat"] == counts["highs"]


def test_item_larger_than_the_cap_is_reported():
    problem = problem_from_incidence(np.eye(2, dtype=bool), [1.0, 1.0], items=((0, 1), (2,)), cap=1)
    with pytest.raises(ValueError, match=r"item 's0\+s1' has 2 blendshapes, more than the cap of 1"):
        solvers.minimum_expressions(problem)


def test_unknown_backend_is_reported():
    with pytest.raises(solvers.UnknownSolverError, match="unknown solver 'gurobi'"):
        solvers.minimum_expressions(random_problem(), solver="gurobi")


def test_the_minimum_mode_is_a_declared_capability():
    assert {"cpsat", "highs"} <= set(solvers.minimum_cover_solvers())
    assert "greedy" not in solvers.minimum_cover_solvers()
    with pytest.raises(ValueError, match="'greedy' cannot prove the fewest expressions; use one of .*cpsat"):
        solvers.minimum_expressions(random_problem(), solver="greedy")


@pytest.mark.parametrize("seed", range(3))
def test_ordered_sequence_keeps_the_minimum_and_maximises_the_first_expression(seed):
    problem = random_problem(8, 14, seed=seed, active=(2, 5))
    result = solvers.ordered_minimum_sequence(problem)
    count = result.minimum.count
    assert len(result.expressions) == count
    _assert_cover(problem, result.expressions)
    # Brute force of step 1: the heaviest packing whose complement fits in count - 1 expressions.
    best, heaviest = 0.0, ()
    for size in range(problem.n_items + 1):
        for chosen in itertools.combinations(range(problem.n_items), size):
            try:
                check_packing(problem, chosen)
            except AssertionError:
                continue
            rest = [i for i in range(problem.n_items) if i not in chosen]
            if not rest or solvers.minimum_expressions(problem.restrict(rest)).count <= count - 1:
                if problem.objective(chosen) > best:
                    best, heaviest = problem.objective(chosen), chosen
    assert result.expressions[0] == heaviest
    assert result.objectives[0] == pytest.approx(problem.unperturbed_objective(heaviest), rel=1e-12)
    assert all(t is Termination.OPTIMAL for t in result.terminations)
