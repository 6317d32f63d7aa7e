"""Speed of the packing analysis, of the presolve and of the problems of a whole expression sequence.

Targets: whole analysis (binary shapes, importance, mirror map, both symmetries, presolve)
<= 1 s on `toon` (N~11.7k, K=65) and `female` (N~5k, K=265); presolve of the full problem from the vertices
and of one expression's problem <= 5 ms on `female`; every problem of a whole greedy sequence, each derived
from the previous one's presolved conflict sets, <= 12 ms on `female` (the packing share of the 20 ms greedy
sequence). Targets are checked on the best of a few repetitions (see ``conftest.speed_target``). Run with
``pytest tests/benchmarks/test_bench_packing.py --benchmark-enable``.
"""

from __future__ import annotations

import functools
import warnings

import numpy as np
import pytest

import packing
import rigs
import solvers
from tests.benchmarks.timing import best_time


@functools.cache
def _generated(preset: str) -> rigs.Rig:
    return rigs.generate(preset, seed=0)


def _target(rig: rigs.Rig) -> np.ndarray:
    """A non-uniformly scaled neutral, so the triangle distortion term (eqs. 6-7) is exercised."""
    return rig.neutral * [1.3, 1.0, 0.9]


def _analyse(rig: rigs.Rig, target: np.ndarray, **params) -> packing.Analysis:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return packing.analyse(rig, target, **params)


@pytest.mark.parametrize("preset", ["toon", "female"])
def test_bench_analysis(benchmark, speed_target, preset):
    rig = _generated(preset)
    target = _target(rig)
    seconds, _ = best_time(lambda: _analyse(rig, target), repeats=2)
    analysis = benchmark(_analyse, rig, target)
    problem = analysis.problem
    benchmark.extra_info.update(
        n_vertices=rig.n_vertices,
        n_shapes=rig.n_shapes,
        n_items=problem.n_items,
        n_pairs=len(analysis.pairs),
        n_self_symmetric=len(analysis.self_symmetric),
        n_empty=len(analysis.empty_names),
        vertex_rows=problem.n_vertex_rows,
        clique_rows=len(problem.cliques),
        steps={step: round(seconds, 5) for step, seconds in analysis.timings.items()},
    )
    assert problem.n_items == rig.n_shapes - len(analysis.pairs) - len(analysis.empty_names)
    assert 0 < len(problem.cliques) < problem.n_vertex_rows
    speed_target(f"analysis of {preset} [s]", seconds, 1.0)


def _half_used(analysis: packing.Analysis) -> list[str]:
    """Shapes of every other item: a mid-sequence state."""
    return list(analysis.problem.shapes_of(range(0, analysis.problem.n_items, 2)))


@pytest.mark.parametrize("preset", ["female"])
def test_bench_expression_presolve(benchmark, speed_target, preset):
    """One iteration of Algorithm 1's set-up from the first problem: drop the used items, reweight,
    presolve anew."""
    rig = _generated(preset)
    analysis = _analyse(rig, _target(rig), beta=0.5)
    used = _half_used(analysis)
    seconds, _ = best_time(lambda: analysis.problem_for(used), repeats=20)
    problem = benchmark(analysis.problem_for, used)
    fresh = packing.problem_from_incidence(problem.incidence, problem.weights, items=problem.items)
    assert [c.tolist() for c in problem.cliques] == [c.tolist() for c in fresh.cliques]
    assert problem.n_vertex_rows == fresh.n_vertex_rows
    benchmark.extra_info.update(
        n_items=problem.n_items, vertex_rows=problem.n_vertex_rows, clique_rows=len(problem.cliques)
    )
    speed_target("problem of one expression, half the items used [s]", seconds, 0.005)


@pytest.mark.parametrize("preset", ["female"])
def test_bench_presolve_from_vertices(benchmark, speed_target, preset):
    """The full presolve of the first expression from its item-by-vertex incidence."""
    rig = _generated(preset)
    problem = _analyse(rig, _target(rig)).problem
    seconds, _ = best_time(lambda: packing._presolve.maximal_conflict_sets(problem.incidence), repeats=20)
    cliques, rows = benchmark(packing._presolve.maximal_conflict_sets, problem.incidence)
    assert rows == problem.n_vertex_rows and len(cliques) == len(problem.cliques)
    benchmark.extra_info.update(n_items=problem.n_items, vertex_rows=rows, clique_rows=len(cliques))
    speed_target("presolve from the vertices [s]", seconds, 0.005)


def _greedy_choices(analysis: packing.Analysis) -> list[tuple[int, ...]]:
    """The items chosen at each step of a greedy sequence (items of each step's problem)."""
    greedy = solvers.get("greedy")
    choices, problem, used = [], analysis.problem_for(), []
    while problem.n_items:
        chosen = greedy.solve(problem).items
        choices.append(chosen)
        used.extend(problem.shapes_of(chosen))
        problem = analysis.next_problem(problem, chosen, used)
    return choices


def _sequence_problems(analysis: packing.Analysis, choices: list[tuple[int, ...]]) -> list:
    """Every problem of the sequence that makes ``choices``, each derived from the previous one."""
    problems, used = [analysis.problem_for()], []
    for chosen in choices[:-1]:
        used.extend(problems[-1].shapes_of(chosen))
        problems.append(analysis.next_problem(problems[-1], chosen, used))
    return problems


@pytest.mark.parametrize("preset", ["female", "digidouble", "male", "toon"])
@pytest.mark.parametrize("beta", [0.0, 0.5])
def test_bench_sequence_problems(benchmark, speed_target, preset, beta):
    """All problems of a whole greedy sequence (Algorithm 1), derived incrementally, without the solver."""
    rig = _generated(preset)
    analysis = _analyse(rig, _target(rig), beta=beta)
    choices = _greedy_choices(analysis)
    seconds, _ = best_time(lambda: _sequence_problems(analysis, choices), repeats=5)
    problems = benchmark(_sequence_problems, analysis, choices)
    used: list[str] = []
    for problem, chosen in zip(problems, choices, strict=True):
        fresh = analysis.problem_for(used)
        assert [c.tolist() for c in problem.cliques] == [c.tolist() for c in fresh.cliques]
        assert problem.weights.tolist() == fresh.weights.tolist()
        assert problem.n_vertex_rows == fresh.n_vertex_rows
        used.extend(problem.shapes_of(chosen))
    benchmark.extra_info.update(
        preset=preset,
        expressions=len(problems),
        per_expression_ms=round(seconds / len(problems) * 1e3, 4),
        first_clique_rows=len(problems[0].cliques),
    )
    if preset == "female" and beta == 0.0:
        speed_target("problems of the whole greedy sequence [s]", seconds, 0.012)
