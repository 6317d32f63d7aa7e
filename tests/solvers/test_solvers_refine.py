"""Artist refinement (sec. 4.5.3): accept/reject proposals, rejections for this expression only."""

from dataclasses import replace

import numpy as np

import packing
import rigs
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
    # every re-solve was optimal: the result is optimal for the problem restricted by the decisions
    assert solution.termination is Termination.OPTIMAL and solution.status == "optimal"
    assert solution.message == (
        f"rejected: {problem.item_label(rejected)} "
        "(optimal without the rejected items, with the accepted ones)"
    )


def test_a_heuristic_after_a_rejection_claims_no_optimum():
    problem = random_problem(14, 30, seed=4)
    decisions = iter([False] + [True] * 30)
    solution = solvers.refine(problem, solvers.get("greedy"), lambda proposal: next(decisions))
    assert solution.termination is Termination.COMPLETED and solution.status == "feasible"


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


def test_the_expression_comes_from_the_sequence_not_from_counting_solves():
    # with extra examples (sec. 6) packing.sequence solves an expression twice, both times as that expression
    problem = random_problem(14, 30, seed=4)
    seen = []
    refining = solvers.RefiningSolver(solvers.get("highs"), lambda p: seen.append(p) or True)
    stages = [(1, "primary"), (2, "primary"), (2, "extra_examples"), (3, "primary")]
    for expression, stage in stages:
        refining.solve(replace(problem, meta={**problem.meta, "expression": expression, "stage": stage}))
    assert sorted({(p.expression, p.extra_example) for p in seen}) == [
        (0, False),
        (1, False),
        (1, True),
        (2, False),
    ]


def test_rejections_follow_expressions_through_the_extra_example_pass():
    rig = rigs.generate("male")
    plain = packing.sequence(rig, solvers.get("cpsat"), jmax=4, extra_examples=True)
    assert all(expression.extra_examples for expression in plain[1:3])  # two extra passes before expression 3
    name = plain[2].shapes[0]
    refining = solvers.RefiningSolver(solvers.get("cpsat"), solvers.rejecting({2: {name}}))
    refined = packing.sequence(rig, refining, jmax=4, extra_examples=True)
    assert [e.shapes for e in refined[:2]] == [e.shapes for e in plain[:2]]
    assert name not in refined[2].shapes + refined[2].extra_examples
    assert refined[2].status == "optimal"


def test_rejecting_one_shape_of_a_pair_rejects_the_pair():
    problem = random_problem(14, 30, seed=5, pairs=1.0)
    optimum = solvers.get("highs").solve(problem)
    pair_shape = optimum.shapes[1]
    solution = solvers.refine(problem, solvers.get("highs"), solvers.rejecting({0: {pair_shape}}))
    assert pair_shape not in solution.shapes
    assert np.isclose(solution.objective, problem.objective(solution.items))
