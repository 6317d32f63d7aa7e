"""Film-scale speed: the ``film`` preset (N = 20k, K = 1,000) and the ``dense`` preset
(N = 100k, K = 265), both on the procedural Female layout, against the alien target.

Targets: on ``film`` the analysis <= 1 s, the whole optimal sequence (``cpsat``, Algorithm 1 until every shape
is used) <= 3 s, the whole greedy sequence <= 0.3 s and the peak memory of analysis and both sequences
<= 1 GB; on ``dense`` all three together <= 3 s and <= 1.5 GB. The peak is the resident-set high-water mark
of a fresh process from the moment its rig and target neutral are loaded (so it includes them, not the
loading), read on Linux from ``/proc``; elsewhere it is not measured. In CPU seconds of this process: the
analysis <= 0.5 s on ``film`` and <= 1 s on ``film`` with 2,000 shapes, whose greedy sequence takes <= 0.6 s
and at most 1.2 times a greedy over the whole problem; the analysis transient stays below 0.3 times the
deltas. Every time is also recorded as a ratio to the same figure on ``female`` measured in the same run, so
that runs on other machines compare. Targets are checked on the best of a few repetitions (see
``conftest.speed_target``).

The timings take a minute of a loaded machine: they run only in a benchmark run (``slow``; run with
``pytest tests/benchmarks/test_bench_film.py --benchmark-enable``). The default run checks the sequences of
film scale's 1,000 shapes (``FILM_SHAPES``, on fewer vertices) instead.
"""

from __future__ import annotations

import functools
import subprocess
import sys
import time
import tracemalloc
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import packing
import rigs
import solvers
from tests.benchmarks.timing import best_time
from tests.packing.test_packing_lazy_restriction import numpy_greedy_sequence

#: Seconds (and megabytes) of the issue, per preset.
TARGETS = {
    "film": {"analysis": 1.0, "optimal": 3.0, "greedy": 0.3, "peak_mb": 1024.0},
    "dense": {"total": 3.0, "peak_mb": 1536.0},
}
REFERENCE = "female"
REPEATS = 2
#: The peak is read from here (Linux).
PROC = Path("/proc/self")
#: The whole sequences run (Algorithm 1 until every shape is used): label -> solver.
SEQUENCES = {"optimal": "cpsat", "greedy": "greedy"}
#: The ``film`` preset's layout and 1,000 shapes on 3,000 vertices: film scale's count of shapes and
#: expressions (about 200 in each sequence) at a fraction of its cost.
FILM_SHAPES = replace(
    rigs.PRESETS["film"],
    name="film-shapes",
    n_vertices=3000,
    description="The film preset's 1,000 shapes on 3,000 vertices.",
)


def _rig(preset: str | rigs.PresetSpec) -> tuple[rigs.Rig, np.ndarray]:
    """The preset's rig and the neutral of its alien warp (the target of eqs. 6-7)."""
    rig = rigs.generate(preset)
    return rig, rigs.warp(rig, "alien").neutral


def _check_sequences(rig: rigs.Rig, analysis: packing.Analysis, sequences: dict) -> None:
    """Every sequence passes the checker and uses every packable shape exactly once."""
    packable = sorted(rig.names[k] for k in np.flatnonzero(analysis.packable))
    for expressions in sequences.values():
        packing.check(rig, expressions, pairs=analysis.pairs)
        assert sorted(shape for expression in expressions for shape in expression.shapes) == packable


def _figures(rig: rigs.Rig, target: np.ndarray) -> tuple[dict[str, float], packing.Analysis, dict]:
    """Seconds of the analysis and of the whole optimal and greedy sequences, with their expressions."""
    analysis_time, analysis = best_time(lambda: packing.analyse(rig, target), REPEATS)
    figures, sequences = {"analysis": analysis_time}, {}
    for label, name in SEQUENCES.items():
        solver = solvers.get(name)
        figures[label], sequences[label] = best_time(
            lambda solver=solver: packing.sequence(rig, solver, analysis=analysis), REPEATS
        )
    figures["total"] = figures["analysis"] + figures["optimal"] + figures["greedy"]
    return figures, analysis, sequences


@functools.cache
def _reference() -> dict[str, float]:
    return _figures(*_rig(REFERENCE))[0]


#: Run in a fresh process: load the rig and the target neutral, forget the loading's high-water mark, then
#: analyse and run both sequences; print the resident-set peak (MB) since the rig was in memory.
_PEAK_SCRIPT = """
import gc, sys
import numpy as np
import packing, rigs, solvers
rig, target = rigs.load(sys.argv[1]), np.load(sys.argv[2])
gc.collect()
with open("/proc/self/clear_refs", "w") as refs:
    refs.write("5")
analysis = packing.analyse(rig, target)
for name in ("cpsat", "greedy"):
    packing.sequence(rig, solvers.get(name), analysis=analysis)
status = dict(line.split(":", 1) for line in open("/proc/self/status"))
print(int(status["VmHWM"].split()[0]) / 1024)
"""


def _peak_mb(rig: rigs.Rig, target: np.ndarray, folder: Path) -> float | None:
    """Peak resident megabytes of analysis and both sequences in a fresh process (None off Linux)."""
    if not (PROC / "clear_refs").exists():
        return None
    rigs.save(rig, folder / "rig.npz")
    np.save(folder / "target.npy", target)
    done = subprocess.run(
        [sys.executable, "-c", _PEAK_SCRIPT, str(folder / "rig.npz"), str(folder / "target.npy")],
        capture_output=True,
        text=True,
        check=True,
    )
    return float(done.stdout.split()[-1])


def test_sequences_of_a_thousand_shapes_use_every_packable_shape():
    rig, target = _rig(FILM_SHAPES)
    analysis = packing.analyse(rig, target)
    sequences = {
        label: packing.sequence(rig, solvers.get(name), analysis=analysis)
        for label, name in SEQUENCES.items()
    }
    assert rig.n_shapes == 1000 and min(len(expressions) for expressions in sequences.values()) > 100
    _check_sequences(rig, analysis, sequences)


@pytest.mark.slow
@pytest.mark.parametrize("preset", list(TARGETS))
def test_bench_film_scale(benchmark, speed_target, tmp_path, preset):
    if benchmark.disabled:
        pytest.skip("the film-scale timings run only with --benchmark-enable")
    rig, target = _rig(preset)
    figures, analysis, sequences = _figures(rig, target)
    _check_sequences(rig, analysis, sequences)
    benchmark.pedantic(
        packing.sequence,
        args=(rig, solvers.get("cpsat")),
        kwargs={"analysis": analysis},
        rounds=1,
        iterations=1,
    )
    peak = _peak_mb(rig, target, tmp_path)
    reference = _reference()
    benchmark.extra_info.update(
        preset=preset,
        n_vertices=rig.n_vertices,
        n_shapes=rig.n_shapes,
        n_items=analysis.problem.n_items,
        clique_rows=len(analysis.problem.cliques),
        optimal_expressions=len(sequences["optimal"]),
        greedy_expressions=len(sequences["greedy"]),
        seconds={name: round(value, 4) for name, value in figures.items()},
        steps={step: round(value, 4) for step, value in analysis.timings.items()},
        peak_mb=None if peak is None else round(peak),
        rig_mb=round((rig.deltas.nbytes + rig.neutral.nbytes + target.nbytes) / 2**20),
        reference=REFERENCE,
        ratio_to_reference={name: round(value / reference[name], 2) for name, value in figures.items()},
    )
    for name, limit in TARGETS[preset].items():
        if name in figures:
            speed_target(f"{name} of {preset} [s]", figures[name], limit)
    if peak is not None:
        speed_target(f"peak memory of {preset} [MB]", peak, TARGETS[preset]["peak_mb"])


#: Film scale at twice the shapes (N = 20k, K = 2,000), for the analysis transient and the greedy sequence.
FILM_2000 = replace(
    rigs.PRESETS["film"],
    name="film-2000",
    n_shapes=2000,
    description="The film preset with 2,000 shapes.",
)
#: Largest transient of the analysis (its traced peak above what it started with) per byte of the rig's
#: deltas, and largest CPU time of the greedy sequence per CPU time of a greedy over the whole problem.
TRANSIENT_SHARE = 0.3
GREEDY_RATIO = 1.2
#: CPU seconds of the analysis and of the whole greedy sequence, per preset (of the 2-core machine the
#: targets were set on).
ANALYSIS_CPU = {"film": 0.5, "film-2000": 1.0}
GREEDY_CPU = {"film-2000": 0.6}
#: Peak resident megabytes of analysis and both whole sequences on ``film`` with 2,000 shapes, the rig and
#: target neutral included (its deltas alone are 916 MB).
FILM_2000_PEAK_MB = 1.3 * 1024


def best_cpu_time(function: Callable[[], Any], repeats: int) -> tuple[float, Any]:
    """Like `best_time`, in CPU seconds of this process (a loaded machine then slows both sides of a
    ratio alike)."""
    times, result = [], None
    for _ in range(repeats):
        start = time.process_time()
        result = function()
        times.append(time.process_time() - start)
    return min(times), result


@functools.cache
def _analysed(preset: str | rigs.PresetSpec) -> tuple[rigs.Rig, packing.Analysis]:
    rig, target = _rig(preset)
    return rig, packing.analyse(rig, target)


@pytest.mark.slow
@pytest.mark.parametrize("preset", ["film", FILM_2000], ids=["film", "film-2000"])
def test_bench_film_analysis_cpu(benchmark, speed_target, preset):
    """CPU seconds of the whole analysis (binary blendshapes, importance, symmetry, items, presolve), best of
    `REPEATS`, with each step's share (wall seconds of the last run)."""
    if benchmark.disabled:
        pytest.skip("the film-scale timings run only with --benchmark-enable")
    rig, target = _rig(preset)
    packing.analyse(rig, target)  # (modules and caches loaded before timing)
    seconds, analysis = best_cpu_time(lambda: packing.analyse(rig, target), REPEATS)
    benchmark.pedantic(packing.analyse, args=(rig, target), rounds=1, iterations=1)
    name = preset if isinstance(preset, str) else preset.name
    benchmark.extra_info.update(
        preset=name,
        n_shapes=rig.n_shapes,
        cpu_seconds=round(seconds, 4),
        steps={step: round(value, 4) for step, value in analysis.timings.items()},
    )
    speed_target(f"analysis of {name} [CPU s]", seconds, ANALYSIS_CPU[name])


@pytest.mark.slow
@pytest.mark.parametrize("preset", ["film", FILM_2000], ids=["film", "film-2000"])
def test_bench_film_analysis_transient(benchmark, speed_target, preset):
    """The analysis holds no (K, N) float array: its traced peak above its start stays below
    `TRANSIENT_SHARE` of the deltas (their K N 3 floats), the step that peaks named."""
    if benchmark.disabled:
        pytest.skip("the film-scale measurements run only with --benchmark-enable")
    rig, target = _rig(preset)
    packing.analyse(rig, target)  # (modules and caches loaded before tracing)
    tracemalloc.start()
    try:
        start = tracemalloc.get_traced_memory()[0]
        analysis = benchmark.pedantic(packing.analyse, args=(rig, target), rounds=1, iterations=1)
        peak = tracemalloc.get_traced_memory()[1] - start
    finally:
        tracemalloc.stop()
    share = peak / rig.deltas.nbytes
    benchmark.extra_info.update(
        preset=rig.provenance.generator.preset if rig.provenance.generator else str(preset),
        n_shapes=rig.n_shapes,
        transient_mb=round(peak / 2**20),
        deltas_mb=round(rig.deltas.nbytes / 2**20),
        share=round(share, 3),
        seconds={step: round(value, 4) for step, value in analysis.timings.items()},
    )
    speed_target(f"analysis transient of {rig.n_shapes} shapes [x deltas]", share, TRANSIENT_SHARE)


@pytest.mark.slow
@pytest.mark.parametrize("preset", ["film", FILM_2000], ids=["film", "film-2000"])
def test_bench_film_greedy_against_numpy_greedy(benchmark, speed_target, preset):
    """The greedy sequence (Algorithm 1 over lazily restricted problems) against a greedy over the whole
    problem that only masks the used items, timed in the same run (CPU seconds, best of `REPEATS`)."""
    if benchmark.disabled:
        pytest.skip("the film-scale timings run only with --benchmark-enable")
    rig, analysis = _analysed(preset)
    greedy = solvers.get("greedy")
    sequence_time, expressions = best_cpu_time(
        lambda: packing.sequence(rig, greedy, analysis=analysis), REPEATS
    )
    reference_time, reference = best_cpu_time(lambda: numpy_greedy_sequence(analysis), REPEATS)
    assert [sorted(e.shapes) for e in expressions] == [sorted(shapes) for shapes in reference]
    benchmark.pedantic(packing.sequence, args=(rig, greedy), kwargs={"analysis": analysis}, rounds=1)
    ratio = sequence_time / reference_time
    benchmark.extra_info.update(
        n_shapes=rig.n_shapes,
        expressions=len(expressions),
        sequence_cpu=round(sequence_time, 4),
        numpy_greedy_cpu=round(reference_time, 4),
        ratio=round(ratio, 3),
    )
    speed_target(f"greedy sequence of {rig.n_shapes} shapes [x numpy greedy]", ratio, GREEDY_RATIO)
    name = preset if isinstance(preset, str) else preset.name
    if name in GREEDY_CPU:
        speed_target(f"greedy sequence of {name} [CPU s]", sequence_time, GREEDY_CPU[name])


@pytest.mark.slow
def test_bench_film_2000_peak_memory(benchmark, speed_target, tmp_path):
    """The resident-set peak of analysis and both whole sequences on 2,000 shapes (`_peak_mb`, a fresh
    process; Linux only)."""
    if benchmark.disabled:
        pytest.skip("the film-scale timings run only with --benchmark-enable")
    rig, target = _rig(FILM_2000)
    peak = benchmark.pedantic(_peak_mb, args=(rig, target, tmp_path), rounds=1, iterations=1)
    if peak is None:
        pytest.skip("the resident-set peak is read from /proc (Linux)")
    rig_mb = (rig.deltas.nbytes + rig.neutral.nbytes + target.nbytes) / 2**20
    benchmark.extra_info.update(peak_mb=round(peak), rig_mb=round(rig_mb))
    speed_target("peak memory of film-2000 [MB]", peak, FILM_2000_PEAK_MB)
