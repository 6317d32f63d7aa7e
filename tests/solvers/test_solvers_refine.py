"""Artist refinement (sec. 4.5.3): accept/reject proposals, rejections for this expression only."""

import numpy as np

import solvers
from packing import Termination
from solvers.testing import brute_force_optimum, check_packing, random_problem


def test_accepting_everything_gives_the_inner_optimum():
    problem = random_problem(14, 30, seed=2)
    proposals = []
    solution = solvers.refine(problem, solvers.get("highs"), lambda p: proposals.append(p) or True)
    optimum = solvers.get("highs").solve(problem)
    assert solution.items == optimum.items and solution.termination is Termination.OPTIMAL
    weights = [p.weight for p in proposals]
    assert weights == sorted(weights, reverse=True)  # best first
    assert solution.backend == "highs+refine"


def test_rejected_first_proposal_gives_the_optimum_without_it():
    problem = random_problem(14, 30, seed=4)
    first = []

    def decide(proposal):
        if not first:
            first.append(proposal.item)
            return False
        return True

    solution = solvers.refine(problem, solvers.get("cpsat"), decide)
    rejected = first[0]
    assert rejected not in solution.items
    check_packing(problem, solution.items)
    without = problem.restrict([i for i in range(problem.n_items) if i != rejected])
    assert solution.objective == brute_force_optimum(without)[0]
    assert solution.termination is Termination.COMPLETED
    assert solution.message == f"rejected: {problem.item_label(rejected)}"


def test_accepted_items_stay_and_alternatives_respect_them_and_the_cap():
    problem = random_problem(14, 30, seed=8, cap=5)
    decisions = iter([True, False, False, True, False] + [True] * 20)
    seen = []

    def decide(proposal):
        seen.append(proposal)
        return next(decisions)

    solution = solvers.refine(problem, solvers.get("highs"), decide)
    accepted = [
        p.item for p, ok in zip(seen, [True, False, False, True, False] + [True] * 20, strict=False) if ok
    ]
    assert set(solution.items) == set(accepted)
    check_packing(problem, solution.items)
    rejected = {p.item for p, ok in zip(seen, [True, False, False, True, False], strict=False) if not ok}
    assert rejected.isdisjoint(solution.items)
    assert all(p.item not in p.accepted for p in seen)


def test_rejections_apply_to_their_expression_only():
    problem = random_problem(14, 30, seed=4)
    best = solvers.get("highs").solve(problem)
    name = best.shapes[0]
    refining = solvers.RefiningSolver(solvers.get("highs"), solvers.rejecting({0: {name}}))
    first = refining.solve(problem)
    second = refining.solve(problem)  # the next expression: the name is proposed again
    assert name not in first.shapes
    assert second.items == best.items


def test_rejecting_one_shape_of_a_pair_rejects_the_pair():
    problem = random_problem(14, 30, seed=5, pairs=1.0)
    optimum = solvers.get("highs").solve(problem)
    pair_shape = optimum.shapes[1]
    solution = solvers.refine(problem, solvers.get("highs"), solvers.rejecting({0: {pair_shape}}))
    assert pair_shape not in solution.shapes
    assert np.isclose(solution.objective, problem.objective(solution.items))
