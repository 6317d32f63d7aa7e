"""A kernel whose conflict graph falls apart is solved component by component (`ExactSolver.solve`): without a
binding cap, eq. 3 (Carrigan et al. 2020) over independent components is the sum of their problems, so the
optimum and its bound are the union and the sum of theirs."""

from __future__ import annotations

import time

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings, strategies as st
from scipy.sparse.csgraph import connected_components

import packing
import solvers
from packing import Termination, pack_bit_rows, problem_from_incidence
from solvers import Capabilities, Result
from solvers._cliques import kernel_components, kernel_neighbourhoods
from solvers._reduce import reduce_problem
from solvers.testing import check_packing
from tests.solvers.plugin_variants import available, variant


def blocks_problem(
    seed: int, n_blocks: int, items_per_block: int, *, cap: int | None = None
) -> packing.PackingProblem:
    """Items of ``n_blocks`` groups on disjoint vertices (two or three random active vertices each, among
    twice as many vertices as the group has items): the groups never conflict with each other."""
    rng = np.random.default_rng(seed)
    blocks = []
    for _ in range(n_blocks):
        dense = np.zeros((items_per_block, 2 * items_per_block), dtype=bool)
        for row in dense:
            row[rng.choice(dense.shape[1], rng.integers(2, 4), replace=False)] = True
        blocks.append(sp.csr_matrix(dense))
    incidence = sp.block_diag(blocks, format="csr")
    return problem_from_incidence(incidence, rng.uniform(0.2, 1.0, incidence.shape[0]), cap=cap)


def _kernel_pieces(problem: packing.PackingProblem) -> list[np.ndarray]:
    reduction = reduce_problem(problem, cap_binds=False)
    closed = kernel_neighbourhoods(problem.conflict_bits, reduction.kept, problem.n_items)
    return [reduction.kept[piece] for piece in kernel_components(closed)]


class _Spy:
    """A subclass of a plugin that records the items of every model its backend is given."""

    @staticmethod
    def of(name: str) -> type:
        plugin = type(available(name).plugin)

        class Spy(plugin):
            models: list[int] = []

            def solve_model(self, model, **kwargs):
                Spy.models.append(model.n_items)
                return super().solve_model(model, **kwargs)

        return Spy


@settings(max_examples=60, deadline=None)
@given(
    n_items=st.integers(1, 120),
    density=st.floats(0.0, 0.2),
    n_blocks=st.integers(1, 5),
    seed=st.integers(0, 2**31),
)
def test_kernel_components_are_the_connected_components(n_items, density, n_blocks, seed):
    rng = np.random.default_rng(seed)
    block = rng.integers(0, n_blocks, n_items)
    upper = np.triu(rng.random((n_items, n_items)) < density, k=1) & (block[:, None] == block[None, :])
    adjacency = upper | upper.T
    pieces = kernel_components(pack_bit_rows(adjacency | np.eye(n_items, dtype=bool)))
    n_components, labels = connected_components(sp.csr_matrix(adjacency), directed=False)
    expected = sorted(tuple(np.flatnonzero(labels == label).tolist()) for label in range(n_components))
    assert sorted(tuple(piece.tolist()) for piece in pieces) == expected
    assert [int(piece[0]) for piece in pieces] == sorted(int(piece[0]) for piece in pieces)
    assert all((np.diff(piece) > 0).all() for piece in pieces)


@pytest.mark.parametrize("n_items", [1, 2, 64, 65, 300])
def test_a_path_is_one_component_and_isolated_items_are_one_each(n_items):
    """The far end of a path is reached one step per pass; isolated items (their own neighbourhood only)
    are components of their own, across word boundaries."""
    step = np.arange(n_items - 1)
    path = np.eye(n_items, dtype=bool)
    path[step, step + 1] = path[step + 1, step] = True
    assert [piece.tolist() for piece in kernel_components(pack_bit_rows(path))] == [list(range(n_items))]
    alone = kernel_components(pack_bit_rows(np.eye(n_items, dtype=bool)))
    assert [piece.tolist() for piece in alone] == [[item] for item in range(n_items)]


@pytest.mark.parametrize("name", ["cpsat", "highs", "cbc-mip"])
@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 10_000), n_blocks=st.integers(2, 4), items_per_block=st.integers(10, 40))
def test_components_solved_apart_give_the_optimum_solved_whole(name, seed, n_blocks, items_per_block):
    problem = blocks_problem(seed, n_blocks, items_per_block)
    apart = available(name).solve(problem)
    whole = variant(name, "Whole", decomposes=False).solve(problem)
    assert apart.termination is whole.termination is Termination.OPTIMAL
    assert apart.items == whole.items
    assert apart.objective == pytest.approx(whole.objective, rel=1e-12)
    assert apart.bound == pytest.approx(apart.objective, rel=1e-12)
    check_packing(problem, apart.items)


def test_the_backend_sees_one_component_at_a_time():
    problem = blocks_problem(2, 3, 40)  # its kernel: three components of 21, 29 and 20 items
    pieces = _kernel_pieces(problem)
    assert len(pieces) == 3 and all(piece.size > 16 for piece in pieces)
    spy = _Spy.of("cpsat")
    solution = solvers.load(spy).solve(problem)
    assert solution.termination is Termination.OPTIMAL
    assert "kernel solved as 3 components" in solution.message
    assert max(spy.models) <= max(piece.size for piece in pieces)
    assert solution.items == available("cpsat").solve(problem).items
    whole = variant("cpsat", "Whole", decomposes=False).solve(problem)
    assert solution.items == whole.items


def test_a_binding_cap_keeps_the_components_together():
    problem = blocks_problem(2, 3, 40, cap=4)
    spy = _Spy.of("cpsat")
    solution = solvers.load(spy).solve(problem)
    assert solution.termination is Termination.OPTIMAL
    assert "components" not in solution.message
    assert max(spy.models) > max(piece.size for piece in _kernel_pieces(blocks_problem(2, 3, 40)))
    assert problem.item_shape_counts[list(solution.items)].sum() <= 4
    assert solution.items == variant("cpsat", "Whole", decomposes=False).solve(problem).items
    check_packing(problem, solution.items)


def test_a_component_stopped_by_its_time_limit_keeps_the_others_optima():
    """One component's backend stops with no incumbent: the answer is TIME_LIMIT, that component gets
    Algorithm 2's packing, the other components keep their optima, and the bound still covers the optimum."""
    problem = blocks_problem(2, 3, 40)
    plugin = type(available("cpsat").plugin)

    class FirstCallStops(plugin):
        calls = 0

        def solve_model(self, model, **kwargs):
            FirstCallStops.calls += 1
            if FirstCallStops.calls == 1:
                return Result((), Termination.TIME_LIMIT, None, 0.0, 0.0)
            return super().solve_model(model, **kwargs)

    stopped = solvers.load(FirstCallStops).solve(problem, time_limit=10.0)
    optimum = available("cpsat").solve(problem)
    assert stopped.termination is Termination.TIME_LIMIT
    assert stopped.fallback == "greedy"
    assert stopped.bound >= optimum.objective - 1e-12
    assert stopped.objective <= optimum.objective + 1e-12
    first, *others = _kernel_pieces(problem)
    for piece in others:  # the components solved to optimality answer their optimum
        assert sorted(set(stopped.items) & set(piece.tolist())) == sorted(
            set(optimum.items) & set(piece.tolist())
        )
    assert set(stopped.items) & set(first.tolist())  # the stopped one still gets a packing
    check_packing(problem, stopped.items)


def _sleeping(name: str, first_call_seconds: float | None = None) -> type:
    """The plugin ``name`` whose backend sleeps through its whole time limit (the first call through
    ``first_call_seconds`` when given) and stops with no incumbent; the limits it got are recorded."""
    plugin = type(available(name).plugin)

    class Sleeping(plugin):
        limits: list[float] = []

        def solve_model(self, model, *, time_limit, seed, start=()):
            Sleeping.limits.append(time_limit)
            seconds = first_call_seconds if first_call_seconds and len(Sleeping.limits) == 1 else time_limit
            time.sleep(seconds)
            return Result((), Termination.TIME_LIMIT, None, 0.0, seconds)

    return Sleeping


def test_each_component_gets_its_share_of_the_time_left():
    """Three components of 21, 29 and 20 items under a 0.3 s limit: the first gets 21/70 of it, each next
    one its share of what is left, so the backend calls together stay within the limit."""
    problem = blocks_problem(2, 3, 40)
    sleeping = _sleeping("cpsat")
    solution = solvers.load(sleeping).solve(problem, time_limit=0.3)
    first, second, third = sleeping.limits
    assert first == pytest.approx(0.3 * 21 / 70)
    assert 0 < second <= (0.3 - first) * 29 / 49 and 0 < third <= 0.3 - first - second
    assert first + second + third <= 0.3
    assert solution.termination is Termination.TIME_LIMIT and solution.fallback == "greedy"
    for piece in _kernel_pieces(problem):  # every component still gets Algorithm 2's packing
        assert set(solution.items) & set(piece.tolist())
    check_packing(problem, solution.items)


def test_a_component_whose_turn_comes_after_the_limit_gets_no_backend_call():
    problem = blocks_problem(2, 3, 40)
    sleeping = _sleeping("cpsat", first_call_seconds=0.2)
    solution = solvers.load(sleeping).solve(problem, time_limit=0.1)
    optimum = available("cpsat").solve(problem)
    assert len(sleeping.limits) == 1
    assert "no time left for this component" in solution.message
    assert solution.termination is Termination.TIME_LIMIT
    assert solution.bound >= optimum.objective - 1e-12
    for piece in _kernel_pieces(problem):
        assert set(solution.items) & set(piece.tolist())
    check_packing(problem, solution.items)


def test_a_plugin_without_a_start_gets_algorithm_2s_packing_for_a_stopped_component():
    problem = blocks_problem(2, 3, 40)
    plugin = type(available("cpsat").plugin)
    cold = Capabilities(exact=True, time_limit=True, minimum_cover=True, warm_start=False)

    class FirstCallStopsCold(plugin):
        capabilities = cold
        calls = 0

        def solve_model(self, model, *, time_limit, seed):
            FirstCallStopsCold.calls += 1
            if FirstCallStopsCold.calls == 1:
                return Result((), Termination.TIME_LIMIT, None, 0.0, 0.0)
            return super().solve_model(model, time_limit=time_limit, seed=seed)

    solution = solvers.load(FirstCallStopsCold).solve(problem, time_limit=10.0)
    optimum = set(available("cpsat").solve(problem).items)
    first, *others = _kernel_pieces(problem)
    assert solution.termination is Termination.TIME_LIMIT and solution.fallback == "greedy"
    assert set(solution.items) & set(first.tolist())
    for piece in others:  # solved to optimality: their optimum stays
        assert set(solution.items) & set(piece.tolist()) == optimum & set(piece.tolist())
    check_packing(problem, solution.items)


@pytest.mark.parametrize("name", ["cpsat", "highs"])
@pytest.mark.parametrize("n_items", [1, 5, 20])
def test_a_kernel_the_reductions_empty_is_solved_under_a_time_limit(name, n_items):
    """Items on vertices of their own conflict with none: the reductions take them all, and the empty
    kernel left is answered without a backend, with or without a time limit."""
    problem = problem_from_incidence(np.eye(n_items, dtype=bool), np.linspace(0.5, 1.0, n_items))
    for time_limit in (None, 5.0):
        solution = available(name).solve(problem, time_limit=time_limit)
        assert solution.termination is Termination.OPTIMAL
        assert solution.items == tuple(range(n_items))
