"""Speed and memory of the anacondar transfer (Wagner et al. 2024) on ARKit-52 rigs with the ``alien`` warp.

Targets: on a 10k-vertex, 52-shape rig the set-up (head fit and factorisations, `transfer._adt.anatomy`)
<= 15 s, then <= 1 s per shape for a transfer with 10 packing-like expressions; the whole transfer on a
26.7k-vertex, 52-shape rig <= 90 s from cold caches. Peak traced memory is recorded. ``slow``: run with
``python -m pytest -m slow tests/benchmarks/test_bench_anacondar.py --benchmark-enable -s``.
"""

from __future__ import annotations

import functools
import time
import tracemalloc

import numpy as np
import pytest

import rigs
import transfer
from tests.transfer.packing_like import packing_weights
from transfer import _adt
from transfer._inputs import check_inputs
from transfer.anacondar import AnaConDaR

SETUP_SECONDS, SECONDS_PER_SHAPE, WHOLE_SECONDS = 15.0, 1.0, 90.0


def _spec(n_vertices: int) -> rigs.PresetSpec:
    return rigs.PresetSpec(
        f"arkit52-{n_vertices}", n_vertices, 52, "ARKit-52 shapes on a denser face.", "arkit52"
    )


@functools.cache
def _case(n_vertices: int, n_expressions: int = 10):
    template = rigs.generate(_spec(n_vertices))
    target = rigs.warp(template, "alien")
    weights = packing_weights(template, n_expressions)
    return template, target, weights, transfer.training_expressions(target, weights)


@pytest.mark.slow
def test_bench_anacondar_10k(benchmark, speed_target):
    template, target, weights, examples = _case(10000)
    method = AnaConDaR()
    _adt._anatomies.clear()
    tracemalloc.start()
    try:
        start = time.perf_counter()
        head = method.anatomy(check_inputs(template, target.neutral, weights, examples, method="anacondar"))
        head.source.factor("inverse"), head.target.factor("inverse"), head.target.factor("forward")
        setup = time.perf_counter() - start
        start = time.perf_counter()
        result = benchmark.pedantic(method, args=(template, target.neutral, weights, examples), rounds=1)
        first = time.perf_counter() - start
        start = time.perf_counter()
        method(template, target.neutral, weights, examples)
        again = time.perf_counter() - start
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    benchmark.extra_info.update(
        n_vertices=template.n_vertices,
        n_shapes=template.n_shapes,
        seconds={"setup": round(setup, 2), "first_call": round(first, 2), "later_call": round(again, 2)},
        seconds_per_shape=round(again / template.n_shapes, 3),
        rms=round(transfer.rms(result, target.deltas), 6),
        dt_rms=round(transfer.rms(transfer.get("dt")(template, target.neutral), target.deltas), 6),
        peak_traced_mib=round(peak / 2**20, 1),
    )
    print(f"\nanacondar on {template.n_vertices} vertices: {benchmark.extra_info}")
    assert np.isfinite(result).all()
    speed_target("anacondar set-up on 10k vertices [s]", setup, SETUP_SECONDS)
    speed_target("anacondar per shape on 10k vertices [s]", again / template.n_shapes, SECONDS_PER_SHAPE)


@pytest.mark.slow
def test_bench_anacondar_26k(benchmark, speed_target):
    template, target, weights, examples = _case(26700)
    method = AnaConDaR()
    _adt._anatomies.clear()
    tracemalloc.start()
    try:
        start = time.perf_counter()
        result = benchmark.pedantic(method, args=(template, target.neutral, weights, examples), rounds=1)
        whole = time.perf_counter() - start
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    benchmark.extra_info.update(
        n_vertices=template.n_vertices,
        n_shapes=template.n_shapes,
        seconds=round(whole, 2),
        rms=round(transfer.rms(result, target.deltas), 6),
        peak_traced_mib=round(peak / 2**20, 1),
    )
    print(f"\nanacondar on {template.n_vertices} vertices: {benchmark.extra_info}")
    assert np.isfinite(result).all()
    speed_target("anacondar whole transfer on 26.7k vertices [s]", whole, WHOLE_SECONDS)
