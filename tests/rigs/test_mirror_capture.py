"""Shape symmetry on captured (jittered) neutrals: the mirror map matched to the surface keeps the pairs.

A neutral whose every vertex is moved 0.3 of the mean edge length in a random direction (a capture or
scan of a symmetric face) keeps its deltas; shape symmetry (sec. 4.4.1, eqs. 9-10) over the mirror map
of the jittered neutral must still find >= 95% of the generator's mirror pairs and no other pair.
"""

from __future__ import annotations

from dataclasses import replace
from functools import cache

import numpy as np
import pytest
from scipy.spatial import cKDTree

import packing
import packing._symmetry
import rigs

REFLECT = np.array([-1.0, 1.0, 1.0])


@cache
def rig_of(preset: str) -> rigs.Rig:
    return rigs.generate(preset)


def mean_edge(rig: rigs.Rig) -> float:
    edges = np.unique(np.sort(rig.triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0)
    return float(np.linalg.norm(rig.neutral[edges[:, 0]] - rig.neutral[edges[:, 1]], axis=1).mean())


def jittered(rig: rigs.Rig, share: float, seed: int) -> rigs.Rig:
    """The rig with every neutral vertex moved ``share`` mean edge lengths in a uniformly random
    direction; the deltas are kept."""
    directions = np.random.default_rng(seed).normal(size=rig.neutral.shape)
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    return replace(rig, neutral=rig.neutral + share * mean_edge(rig) * directions)


def mirror_image_truth(rig: rigs.Rig) -> set[frozenset[str]]:
    """The generator's mirror pairs whose two shapes are exact mirror images of each other."""
    distance, mirror = cKDTree(rig.neutral).query(rig.neutral * REFLECT)
    assert distance.max() == 0.0
    return {
        frozenset(pair)
        for pair in rig.truth.mirror_pairs
        if np.array_equal(rig.deltas[rig.index(pair[1])], rig.deltas[rig.index(pair[0])][mirror] * REFLECT)
    }


def shape_pairs(rig: rigs.Rig) -> set[frozenset[str]]:
    """Shape symmetry as packing runs it (`packing.find_symmetry_pairs`, no motion pairs): over the mirror
    map matched to the rig's surface."""
    return {frozenset(pair) for pair in packing.find_symmetry_pairs(rig, motion=False)}


@pytest.mark.parametrize("preset", ["male", "female"])
def test_unjittered_rig_finds_exactly_the_truth(preset):
    rig = rig_of(preset)
    assert shape_pairs(rig) == mirror_image_truth(rig)


@pytest.mark.parametrize("preset", ["male", "female"])
@pytest.mark.parametrize("seed", [0, 1])
def test_jitter_of_three_tenths_of_an_edge_keeps_the_pairs(preset, seed):
    rig = rig_of(preset)
    truth = mirror_image_truth(rig)
    found = shape_pairs(jittered(rig, 0.3, seed))
    assert not found - truth, f"false pairs: {sorted(map(sorted, found - truth))}"
    assert len(found & truth) >= 0.95 * len(truth), f"missed: {sorted(map(sorted, truth - found))}"
