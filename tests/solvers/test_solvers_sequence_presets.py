"""Everything that speeds the exact sequence up keeps its optima (Carrigan et al. 2020, Algorithm 1 over
eq. 3): on every preset, the whole sequence with the reductions, the grown clique rows, reduced-cost fixing,
enumeration of small kernels and components solved apart chooses, at every expression, the items and the
objective that the backend chooses on the presolved problem as it is (``reduces = False``)."""

from __future__ import annotations

import functools
import warnings
from dataclasses import replace

import pytest

import packing
import rigs
from tests.solvers.plugin_variants import available, variant

#: The film-scale presets at a size a test can solve without any reduction (their layout and generator
#: are the same).
SHRUNK = {"film": {"n_vertices": 3000, "n_shapes": 300}, "dense": {"n_vertices": 3000, "n_shapes": 300}}


@functools.cache
def _analysis(preset: str) -> tuple[rigs.Rig, packing.Analysis]:
    spec = replace(rigs.PRESETS[preset], **SHRUNK.get(preset, {}))
    rig = rigs.generate(spec)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", packing.MissingTargetWarning)
        return rig, packing.analyse(rig, rigs.warp(rig, "alien").neutral)


@pytest.mark.parametrize("preset", sorted(rigs.PRESETS))
@pytest.mark.parametrize("name", ["cpsat", "highs"])
def test_the_sequence_keeps_the_plain_models_optimum_at_every_expression(name, preset):
    rig, analysis = _analysis(preset)
    fast = packing.sequence(rig, available(name), analysis=analysis)
    plain = packing.sequence(rig, variant(name, "Plain", reduces=False), analysis=analysis)
    packing.check(rig, fast, pairs=analysis.pairs)
    assert all(e.solution.termination is packing.Termination.OPTIMAL for e in fast + plain)
    assert [e.items for e in fast] == [e.items for e in plain]
    assert [e.objective for e in fast] == pytest.approx([e.objective for e in plain], rel=1e-12)
