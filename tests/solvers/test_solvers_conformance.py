"""Every registered solver plugin passes the public conformance suite (`solvers.testing`), one check per
test, and the suite fails plugins that break each rule."""

import dataclasses

import numpy as np
import pytest

import packing
import solvers
from packing import Termination
from solvers import Capabilities, Result
from solvers._base import make_solution
from solvers.greedy import GreedyOverlapSolver, GreedySolver
from solvers.testing import CHECKS, check_solver, parametrize_with_checks

#: Every solver the registry knows (available or not: an unavailable one is skipped with its reason).
REGISTERED = solvers.names()


@pytest.fixture(params=REGISTERED)
def built_in(request):
    found = solvers.availability(request.param)
    if not found:
        pytest.skip(f"{request.param} unavailable here: {found.reason}")
    return solvers.get(request.param)


@pytest.mark.parametrize("name", list(CHECKS))
def test_built_in_solver_passes_each_check(built_in, name):
    CHECKS[name](built_in)


@parametrize_with_checks([GreedyOverlapSolver(0.25), GreedyOverlapSolver(0.5)])
def test_greedy_overlap_passes_each_check_at_other_fractions(solver, check):
    check(solver)


def test_check_solver_runs_every_check_and_names_them():
    assert check_solver(GreedySolver) == list(CHECKS)


class DoNothing:
    """A heuristic that returns no items at all."""

    name = "do-nothing"
    capabilities = Capabilities(exact=False, time_limit=False)

    @classmethod
    def availability(cls):
        return solvers.Availability.available("1.0")

    def solve(self, problem, *, time_limit=None, seed=0):
        return Result((), Termination.COMPLETED)


def test_check_solver_fails_a_do_nothing_heuristic():
    with pytest.raises(AssertionError, match="check 'maximality'.*still fit"):
        check_solver(DoNothing)


def test_check_solver_catches_items_outside_the_problem():
    class OutOfRange(DoNothing):
        def solve(self, problem, *, time_limit=None, seed=0):
            return Result((problem.n_items,), Termination.COMPLETED)

    with pytest.raises(AssertionError, match="check 'answer'.*not items of a problem"):
        check_solver(OutOfRange)


def test_check_solver_catches_an_answer_that_is_not_a_result():
    class Sloppy(DoNothing):
        def solve(self, problem, *, time_limit=None, seed=0):
            return [0]

    with pytest.raises(AssertionError, match="not a solvers.Result"):
        check_solver(Sloppy)


def test_a_plugin_answers_a_result_and_nothing_else():
    """A `packing.Solution` is the framework's answer, not a plugin's: the checks refuse a plugin that
    returns one (only the framework's own wrappers answer Solutions)."""

    class Presumptuous(DoNothing):
        def solve(self, problem, *, time_limit=None, seed=0):
            return make_solution(
                problem, (), termination=Termination.COMPLETED, bound=None, build_time=0.0, solve_time=0.0,
                backend="presumptuous", version="1",
            )  # fmt: skip

    with pytest.raises(AssertionError, match="solve returned Solution, not a solvers.Result"):
        check_solver(Presumptuous)


def test_check_solver_catches_an_overlapping_packing():
    class Overlapping(DoNothing):
        def solve(self, problem, *, time_limit=None, seed=0):
            return Result(range(problem.n_items), Termination.COMPLETED)

    with pytest.raises(AssertionError, match="check 'validity'.*invalid expression"):
        check_solver(Overlapping)


def test_check_solver_catches_a_joined_apart_pair():
    class JoinsApart(GreedySolver):
        def solve(self, problem, *, time_limit=None, seed=0):
            found = super().solve(problem)
            joined = {i for pair in problem.apart for i in pair}
            return dataclasses.replace(found, items=tuple(sorted(set(found.items) | joined)))

    with pytest.raises(AssertionError, match="apart but both chosen"):
        check_solver(JoinsApart)


def test_check_solver_catches_a_suboptimal_exact_solver():
    class NotExact(GreedySolver):
        capabilities = Capabilities(exact=True, time_limit=False)

    with pytest.raises(AssertionError, match="brute-force optimum|exact solver ended"):
        check_solver(NotExact)


def test_check_solver_catches_a_nondeterministic_solver():
    class Coin(GreedySolver):
        calls = 0

        def solve(self, problem, *, time_limit=None, seed=0):
            Coin.calls += 1
            found = super().solve(problem)
            return dataclasses.replace(found, items=found.items[: -1 if Coin.calls % 2 else None])

    with pytest.raises(AssertionError, match="check '(maximality|determinism)'"):
        check_solver(Coin)


def test_the_framework_fills_what_a_plugin_leaves_out():
    problem = solvers.testing.random_problem(8, 20, seed=3)
    solution = solvers.load(GreedySolver).solve(problem)
    assert solution.objective == pytest.approx(problem.unperturbed_objective(solution.items))
    assert solution.shapes == problem.shapes_of(solution.items)
    assert solution.backend == "greedy" and solution.version
    assert solution.items == tuple(sorted(solution.items))


def test_the_framework_checks_arguments_before_the_plugin_runs():
    problem = solvers.testing.random_problem(5, 10, seed=1)
    loaded = solvers.load(DoNothing)
    for arguments in ({"time_limit": -1.0}, {"time_limit": np.nan}, {"seed": -1}, {"seed": 2**31}):
        with pytest.raises(ValueError):
            loaded.solve(problem, **arguments)
    with pytest.raises(TypeError, match="PackingProblem"):
        loaded.solve("not a problem")


def test_a_plugin_that_raises_is_an_error_solution_naming_it():
    class Broken(DoNothing):
        def solve(self, problem, *, time_limit=None, seed=0):
            raise RuntimeError("backend crashed")

    solution = solvers.load(Broken).solve(solvers.testing.random_problem(5, 10, seed=1))
    assert solution.termination is Termination.ERROR and solution.items == ()
    assert "do-nothing: RuntimeError: backend crashed" in solution.message


@pytest.mark.parametrize("honours_limits", [True, False])
def test_a_search_well_past_its_time_limit_is_said_in_the_answer(monkeypatch, honours_limits):
    """A plugin that declares it honours time limits and searches past one keeps its answer, with the
    overrun said; one that never claimed to is not judged by the limit (the cell's timeout stops it)."""
    import solvers._loaded as loaded_module

    clock = iter([0.0, 2.5])
    monkeypatch.setattr(loaded_module.time, "perf_counter", lambda: next(clock))

    class Overrunning(DoNothing):
        name = "overrunning"
        capabilities = Capabilities(exact=False, time_limit=honours_limits)

        def solve(self, problem, *, time_limit=None, seed=0):
            return Result((), Termination.COMPLETED)

    solution = solvers.load(Overrunning).solve(solvers.testing.random_problem(5, 10, seed=1), time_limit=1.0)
    said = "overran its time limit: searched 2.5 s, limit 1 s"
    assert (said in solution.message) == honours_limits and solution.termination is Termination.COMPLETED
    clock = iter([0.0, 1.7])  # (within the allowed overshoot: 1.25 + 0.5 s)
    assert (
        "overran"
        not in solvers.load(Overrunning)
        .solve(solvers.testing.random_problem(5, 10, seed=1), time_limit=1.0)
        .message
    )


def test_an_exact_plugin_answering_items_outside_its_model_is_an_error():
    class Wrapping(solvers.ExactSolver):
        name = "wrapping"
        capabilities = Capabilities(exact=True, time_limit=False)
        _enumerates_small_kernels = False  # every kernel goes to the backend

        @classmethod
        def availability(cls):
            return solvers.Availability.available("1.0")

        def solve_model(self, model, *, time_limit, seed):
            return Result([-1], Termination.OPTIMAL)

    problem = solvers.testing.face_like_problem(40, 400, seed=1)
    solution = solvers.load(Wrapping).solve(problem)
    assert solution.termination is Termination.ERROR and solution.items == ()
    assert "answered items [-1]" in solution.message


def test_the_sequence_refuses_a_plugin_not_behind_the_framework():
    import rigs

    with pytest.raises(TypeError, match="pass solvers.get\\(name\\) or solvers.load\\(plugin\\)"):
        packing.sequence(rigs.generate("tiny"), GreedySolver())
    assert packing.sequence(rigs.generate("tiny"), solvers.load(GreedySolver))
