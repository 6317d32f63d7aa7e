"""Speed and memory of blendshape transfer on paper-sized generated rigs with the ``alien`` warp.

Targets (issue 5): `ebfr` with J=20 expressions <= 10 s on `toon` (N~11.7k, K=65) and on `female`
(N~5k, K=265); `dt` of every `toon` shape <= 5 s; peak memory <= 4 GiB. Run with
``pytest tests/benchmarks/test_bench_transfer.py --benchmark-enable -s``; ``extra_info`` records the
RMS error, the coverage and the peak traced memory.
"""

from __future__ import annotations

import functools
import time
import tracemalloc

import numpy as np
import pytest

import rigs
import transfer

MEMORY_LIMIT = 4 * 2**30


@functools.cache
def _case(preset: str, n_expressions: int) -> tuple[rigs.Rig, rigs.Rig, np.ndarray, np.ndarray]:
    """Template, warped target, packing-like 0/1 weights and the copied training expressions."""
    template = rigs.generate(preset, seed=0)
    target = rigs.warp(template, "alien")
    length = np.linalg.norm(template.deltas, axis=-1)
    active = length >= 0.3 * length.max(axis=1, keepdims=True)
    order = list(np.argsort(-active.sum(axis=1), kind="stable"))
    rows: list[np.ndarray] = []
    remaining = list(order)
    while len(rows) < n_expressions:  # first-fit greedy of disjoint active sets, repeated when all are placed
        remaining = remaining or list(order)
        used = np.zeros(template.n_vertices, dtype=bool)
        row = np.zeros(template.n_shapes)
        for shape in list(remaining):
            if not (active[shape] & used).any():
                used |= active[shape]
                row[shape] = 1.0
                remaining.remove(shape)
        rows.append(row)
    weights = np.array(rows).reshape(-1, template.n_shapes)
    return template, target, weights, transfer.training_expressions(target, weights)


def _run(benchmark, speed_target, limit, method, template, target, weights, examples) -> np.ndarray:
    tracemalloc.start()
    try:
        start = time.perf_counter()
        result = benchmark.pedantic(
            method,
            args=(template, target.neutral, weights, examples),
            rounds=3,
            iterations=1,
            warmup_rounds=0,
        )
        once = time.perf_counter() - start
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    metrics = transfer.metrics(result, target.deltas, weights)
    benchmark.extra_info.update(
        n_vertices=template.n_vertices,
        n_shapes=template.n_shapes,
        n_expressions=int(weights.shape[0]),
        n_covered=metrics.n_covered,
        rms=round(metrics.rms, 6),
        peak_traced_mib=round(peak / 2**20, 1),
    )
    print(f"\n{method.name} on {template.meta.get('source')}: {benchmark.extra_info}")
    assert peak <= MEMORY_LIMIT
    seconds = benchmark.stats.stats.min if benchmark.stats else once
    speed_target(f"{method.name} on {template.meta.get('source')} [s]", seconds, limit)
    return result


@pytest.mark.parametrize("preset", ["toon", "female"])
def test_bench_ebfr(benchmark, speed_target, preset):
    template, target, weights, examples = _case(preset, 20)
    result = _run(benchmark, speed_target, 10.0, transfer.get("ebfr"), template, target, weights, examples)
    assert transfer.rms(result, target.deltas) < transfer.rms(np.zeros_like(result), target.deltas)


def test_bench_dt_toon(benchmark, speed_target):
    template, target, _, _ = _case("toon", 0)
    empty = np.zeros((0, template.n_shapes))
    no_examples = np.zeros((0, template.n_vertices, 3))
    result = _run(benchmark, speed_target, 5.0, transfer.get("dt"), template, target, empty, no_examples)
    assert result.shape == template.deltas.shape
