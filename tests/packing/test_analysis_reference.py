"""`packing.analyse` against a straightforward reference computed from the dense (K, N) definitions: binary
blendshapes (eq. 2), the importance terms (eqs. 5-7), the mirror pairs and self-symmetric shapes (eqs.
9-10, every pair of shapes evaluated), the items and their maximal conflict sets, on generated rigs of
several presets and seeds.

Tolerances: masks, empty shapes, pairs, self-symmetric shapes, items and conflict sets are compared exactly.
The importance terms are sums of up to N lengths taken in another order, so they agree to a relative
``1e-12`` (N eps for N <= 2,000 is ~4e-13). The eq. 9 errors are checked as `assert_same` of the exhaustive
search does: relative ``1e-9``, or ``1e-12`` of the largest displacement for exact mirror pairs, whose
errors are rounding noise.
"""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

import packing
import rigs
from packing._shape_symmetry import axis_distances, reflection_normal
from tests.packing.test_packing_speed_symmetry import assert_same, exhaustive_shape_symmetry

#: The film layout (many shapes per region, as at film scale) at a size the dense reference affords.
FILM_LAYOUT = replace(rigs.PRESETS["film"], name="film-reference", n_vertices=1500, n_shapes=120)
PRESETS = {"tiny": "tiny", "arkit52": "arkit52", "male": "male", "film": FILM_LAYOUT}


def reference_masks(rig: rigs.Rig, mu: float, noise_floor: float) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 2 on the dense lengths: (K, N) masks and (K,) empty shapes."""
    norms = np.sqrt(np.einsum("knd,knd->kn", rig.deltas, rig.deltas))
    largest = norms.max(axis=1)
    empty = largest <= noise_floor * rig.diagonal()
    masks = (norms >= mu * largest[:, None]) & ~empty[:, None]
    return masks, empty


def reference_importance(rig: rigs.Rig, target: np.ndarray, masks: np.ndarray) -> tuple[np.ndarray, ...]:
    """``lambda_Dis`` (eq. 5) and ``lambda_TD`` (eqs. 6-7) from the dense masks, one shape at a time."""
    norms = np.linalg.norm(rig.deltas, axis=2)
    counts = masks.sum(axis=1)
    mean = np.array([norms[k][masks[k]].mean() if counts[k] else 0.0 for k in range(rig.n_shapes)])
    triangles = rig.triangles
    ratios = []
    for corner in (0, 2):
        length_a = np.linalg.norm(rig.neutral[triangles[:, corner]] - rig.neutral[triangles[:, 1]], axis=1)
        length_b = np.linalg.norm(target[triangles[:, corner]] - target[triangles[:, 1]], axis=1)
        ratios.append(np.maximum(length_a / length_b, length_b / length_a))
    distortion = ratios[0] + ratios[1]
    touched = masks[:, triangles].any(axis=2)  # (K, T): a triangle counts when any corner is active
    summed = np.array([distortion[touched[k]].sum() for k in range(rig.n_shapes)])
    return mean / mean.max(), summed / summed.max()


def reference_conflict_sets(incidence: np.ndarray) -> set[frozenset[int]]:
    """The distinct sets of items sharing a vertex, of two items or more, not inside another such set."""
    sets = {frozenset(np.flatnonzero(column).tolist()) for column in incidence.T}
    sets = {found for found in sets if len(found) > 1}
    return {found for found in sets if not any(found < other for other in sets)}


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(preset=st.sampled_from(sorted(PRESETS)), seed=st.integers(0, 1000))
def test_analysis_equals_the_dense_reference(preset, seed):
    rig = rigs.generate(PRESETS[preset], seed=seed)
    target = rigs.warp(rig, "alien").neutral
    analysis = packing.analyse(rig, target)
    params = analysis.params

    masks, empty = reference_masks(rig, params.mu, params.noise_floor)
    assert np.array_equal(analysis.masks, masks) and np.array_equal(analysis.empty, empty)

    displacement, distortion = reference_importance(rig, target, masks)
    assert analysis.terms.displacement == pytest.approx(displacement, rel=1e-12, abs=0)
    assert analysis.terms.distortion == pytest.approx(distortion, rel=1e-12, abs=0)

    mirror = rigs.mirror_map(rig.neutral, tol=params.mirror_tol, triangles=rig.triangles)
    normal = reflection_normal(rig.neutral, mirror)
    norms = np.linalg.norm(rig.deltas, axis=2)
    reference = exhaustive_shape_symmetry(
        rig.deltas,
        norms,
        masks,
        mirror,
        normal,
        ~empty,
        params.shape_tol,
        params.pair_overlap,
        axis_distances(rig.neutral, mirror, normal),
    )
    symmetry = analysis.symmetry
    found = [(a, b, error) for (a, b), error in zip(symmetry.shape_pairs, symmetry.shape_errors, strict=True)]
    self_symmetric = np.zeros(rig.n_shapes, dtype=bool)
    self_symmetric[list(symmetry.self_symmetric)] = True
    spread = [(a, b, 0.0) for a, b in symmetry.overlapping]
    assert_same((found, self_symmetric, spread), reference, float(norms.max()))

    pairs = {frozenset(pair) for pair in symmetry.pairs}
    partner = {k: other for pair in symmetry.pairs for k, other in itertools.permutations(pair)}
    items = [(k, partner[k]) if k in partner else (k,) for k in range(rig.n_shapes) if not empty[k]]
    items = [item for item in items if len(item) == 1 or item[0] < item[1]]
    assert [tuple(sorted(item)) for item in analysis.problem.items] == items
    assert all(frozenset(item) in pairs for item in items if len(item) == 2)
    incidence = np.array([masks[list(item)].any(axis=0) for item in items])
    cliques = {frozenset(int(i) for i in clique) for clique in analysis.problem.cliques}
    assert cliques and cliques == reference_conflict_sets(incidence)
