"""Algorithm 2 (greedy), its allowed-overlap variant and the (1,2)-swap local search."""

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings, strategies as st

import solvers
from packing import problem_from_incidence
from solvers.greedy import greedy_order, greedy_scores
from solvers.local_search import swap_local_search
from solvers.testing import brute_force_optimum, check_packing, random_problem


def test_greedy_key_is_inverted_importance_times_active_count():
    incidence = np.array([[1, 1, 1, 1, 0, 0], [0, 0, 0, 1, 1, 0], [0, 0, 0, 0, 1, 1]], dtype=bool)
    problem = problem_from_incidence(incidence, [0.9, 0.2, 1.2], items=((0,), (1,), (2, 3)))
    # lambda per shape: 0.9, 0.2, 0.6; lambda_max = 1; keys (1-0.9)*4, (1-0.2)*2, (1-0.6)*2.
    np.testing.assert_allclose(greedy_scores(problem), [0.4, 1.6, 0.8])
    solution = solvers.get("greedy").solve(problem)
    assert solution.items == (0, 2) and solution.shapes == ("s0", "s2", "s3")


def test_lambda_max_covers_weights_above_one():
    problem = problem_from_incidence(np.eye(2, dtype=bool), [3.0, 1.0])
    np.testing.assert_allclose(greedy_scores(problem), [0.0, 2.0])


def test_greedy_respects_the_cap_and_keeps_looking_for_items_that_fit():
    problem = problem_from_incidence(
        np.eye(3, dtype=bool), [0.9, 0.8, 0.1], items=((0,), (1, 2), (3,)), cap=2
    )
    assert solvers.get("greedy").solve(problem).items == (0, 2)


def test_overlap_fraction_is_relative_to_the_added_item():
    incidence = np.zeros((2, 8), dtype=bool)
    incidence[0, :4] = True
    incidence[1, 3:8] = True  # 1 of its 5 vertices is shared
    problem = problem_from_incidence(incidence, [0.9, 0.9])
    assert solvers.get("greedy-overlap", overlap=0.2).solve(problem).items == (0, 1)
    assert solvers.get("greedy-overlap", overlap=0.19).solve(problem).items == (0,)
    solution = solvers.get("greedy-overlap", overlap=0.2).solve(problem)
    assert solution.message == "overlap_allowed=0.2"
    check_packing(problem, solution.items, overlap=0.2)
    with pytest.raises(AssertionError, match="share vertex 3"):
        check_packing(problem, solution.items)


def test_overlap_check_rejects_more_overlap_than_allowed():
    incidence = np.zeros((2, 4), dtype=bool)
    incidence[0, :2] = incidence[1, 1:3] = True
    problem = problem_from_incidence(incidence, [1.0, 1.0])
    check_packing(problem, (0, 1), overlap=0.5)
    with pytest.raises(AssertionError, match="overlap by more than 0.4"):
        check_packing(problem, (0, 1), overlap=0.4)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10**6), cap=st.one_of(st.none(), st.integers(2, 8)))
def test_swap_search_is_valid_and_never_worse_than_greedy(seed, cap):
    problem = random_problem(14, 30, seed=seed, active=(2, 7), cap=cap)
    greedy = solvers.get("greedy").solve(problem)
    swap = solvers.get("greedy-swap").solve(problem)
    check_packing(problem, swap.items)
    assert swap.objective >= greedy.objective - 1e-12
    assert swap.objective <= brute_force_optimum(problem)[0] + 1e-12


def test_swap_search_is_locally_optimal_for_single_swaps():
    problem = random_problem(60, 120, seed=11, active=(3, 9))
    items = set(swap_local_search(problem))
    for dropped in items:
        for added in set(range(problem.n_items)) - items:
            candidate = (items - {dropped}) | {added}
            try:
                check_packing(problem, candidate)
            except AssertionError:
                continue
            assert problem.objective(candidate) <= problem.objective(items) + 1e-12


def test_without_importance_greedy_visits_the_smallest_items_first():
    """Every weight 1: Algorithm 2's key is 0 for all, so fewer active vertices go first (sec. 4.5.2)."""
    sizes = [5, 1, 3, 2]
    incidence = sp.csr_matrix(np.array([[1] * s + [0] * (10 - s) for s in sizes], dtype=bool)[:, ::-1].copy())
    problem = problem_from_incidence(incidence, np.ones(4))
    assert greedy_order(problem).tolist() == [1, 3, 2, 0]
