"""Speed of the packing analysis and of one expression's presolve on paper-sized generated rigs.

Targets (issue 3): whole analysis (binary shapes, importance, mirror map, both symmetries, presolve)
<= 1 s on `toon` (N~11.7k, K=65) and `female` (N~5k, K=265); presolve of one expression's problem
<= 5 ms on `female`. Run with ``pytest tests/benchmarks/test_bench_packing.py --benchmark-enable``.
"""

from __future__ import annotations

import functools
import warnings

import numpy as np
import pytest

import packing
import rigs


@functools.cache
def _generated(preset: str) -> rigs.Rig:
    return rigs.generate(preset, seed=0)


def _target(rig: rigs.Rig) -> np.ndarray:
    """A non-uniformly scaled neutral, so the triangle distortion term (eqs. 6-7) is exercised."""
    return rig.neutral * [1.3, 1.0, 0.9]


def _analyse(rig: rigs.Rig, target: np.ndarray) -> packing.Analysis:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return packing.analyse(rig, target)


@pytest.mark.parametrize("preset", ["toon", "female"])
def test_bench_analysis(benchmark, preset):
    rig = _generated(preset)
    target = _target(rig)
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


def _half_used(analysis: packing.Analysis) -> list[str]:
    """Shapes of every other item: a mid-sequence state."""
    return list(analysis.problem.shapes_of(range(0, analysis.problem.n_items, 2)))


@pytest.mark.parametrize("preset", ["female"])
def test_bench_expression_presolve(benchmark, preset):
    """One iteration of Algorithm 1's set-up: drop the used items, reweight, presolve anew."""
    rig = _generated(preset)
    analysis = packing.analyse(rig, _target(rig), beta=0.5)
    used = _half_used(analysis)
    problem = benchmark(analysis.problem_for, used)
    fresh = packing.problem_from_incidence(problem.incidence, problem.weights, items=problem.items)
    assert [c.tolist() for c in problem.cliques] == [c.tolist() for c in fresh.cliques]
    benchmark.extra_info.update(
        n_items=problem.n_items, vertex_rows=problem.n_vertex_rows, clique_rows=len(problem.cliques)
    )


@pytest.mark.parametrize("preset", ["female"])
def test_bench_presolve_from_vertices(benchmark, preset):
    """The full presolve of the first expression from its item-by-vertex incidence."""
    rig = _generated(preset)
    problem = packing.analyse(rig, _target(rig)).problem
    cliques, rows = benchmark(packing._presolve.maximal_conflict_sets, problem.incidence)
    assert rows == problem.n_vertex_rows and len(cliques) == len(problem.cliques)
    benchmark.extra_info.update(n_items=problem.n_items, vertex_rows=rows, clique_rows=len(cliques))
