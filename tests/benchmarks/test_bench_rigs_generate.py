"""Procedural rig speed: generating the paper-sized presets (female <= 1 s, toon <= 1.5 s) and warping one."""

from __future__ import annotations

import numpy as np
import pytest

import rigs

#: Budgets of the issue, in seconds, recorded next to the measurement (no timed assertion here).
BUDGET = {"female": 1.0, "toon": 1.5, "male": 1.5, "digidouble": 1.0}


@pytest.mark.parametrize("preset", list(BUDGET))
def test_bench_generate(benchmark, preset):
    rig = benchmark(rigs.generate, preset, seed=0)
    spec = rigs.PRESETS[preset]
    norms = np.linalg.norm(rig.deltas, axis=2)
    active = norms >= 0.3 * norms.max(axis=1, keepdims=True)
    benchmark.extra_info.update(
        budget_seconds=BUDGET[preset],
        n_vertices=rig.n_vertices,
        n_vertices_error=(rig.n_vertices - spec.n_vertices) / spec.n_vertices,
        n_shapes=rig.n_shapes,
        mean_active_vertices=float(active.sum(axis=1).mean()),
        mirror_pairs=len(rig.truth.mirror_pairs),
        motion_pairs=len(rig.truth.motion_pairs),
    )
    assert rig.n_shapes == spec.n_shapes


def test_bench_warp_alien_female(benchmark):
    rig = rigs.generate("female")
    target = benchmark(rigs.warp, rig, "alien")
    benchmark.extra_info.update(
        n_vertices=rig.n_vertices,
        n_shapes=rig.n_shapes,
        max_neutral_shift=float(np.linalg.norm(target.neutral - rig.neutral, axis=1).max()),
    )
    assert target.n_shapes == rig.n_shapes
