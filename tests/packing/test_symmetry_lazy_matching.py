"""The lazy matching of mirror pairs (scores evaluated in order of their floors) against the greedy matching
over every scored pair, and the floors of the candidate bounds against the exact eq. 9 scores."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import packing._shape_symmetry as symmetry
import rigs
from packing._binary import entries, sparse_masks
from packing._symmetry_candidates import (
    candidate_pairs,
    cell_sums,
    self_candidates,
    vertex_cells,
)
from packing._symmetry_field import Preimages, SymmetryField, mirrored_lengths, row_sums
from tests.packing.test_packing_speed_symmetry import inputs


@settings(max_examples=200, deadline=None)
@given(
    n_shapes=st.integers(2, 12),
    seed=st.integers(0, 2**32 - 1),
    batch=st.sampled_from([1, 2, 3, 256]),
    levels=st.integers(1, 6),
)
def test_lazy_matching_equals_the_greedy_matching_of_every_score(n_shapes, seed, batch, levels):
    """Scores from a few levels (ties), floors at or below them (some equal), limits cutting some off."""
    rng = np.random.default_rng(seed)
    first, second = np.triu_indices(n_shapes, k=1)
    kept = rng.random(first.size) < 0.7
    first, second = first[kept], second[kept]
    score = rng.integers(0, levels, first.size) / levels
    floor = np.where(rng.random(first.size) < 0.3, score, score - rng.random(first.size))
    limit = rng.uniform(0.2, 1.2, first.size)
    scored: list[int] = []

    def scores_of(pairs: np.ndarray) -> np.ndarray:
        scored.extend(pairs.tolist())
        return score[pairs]

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(symmetry, "EVALUATION_BATCH", batch)
        lazy = symmetry.match_lazily(first, second, floor, limit, scores_of, n_shapes)
    passing = score < limit
    assert lazy == symmetry.match_pairs(first[passing], second[passing], score[passing])
    assert len(scored) == len(set(scored))  # each pair scored once at most


@pytest.fixture(scope="module", params=["mirror cells", "grid cells"])
def female(request) -> SimpleNamespace:
    """The symmetry step's inputs on the ``female`` rig, up to the per-cell sums of the candidate bounds: over
    cells that are mirror images of each other (as `shape_symmetry` makes them for an involutive mirror map)
    or over a plain grid (as for any other map)."""
    rig = rigs.generate("female")
    norms, masks, mirror, normal, eligible, _ = inputs(rig)
    active = sparse_masks(masks)
    rows, cols = entries(active)
    field = SymmetryField.of(rig.deltas, norms, active, rows, cols, normal)
    preimages = Preimages.of(mirror, cols)
    mirrored = request.param == "mirror cells"
    cells, flip = vertex_cells(rig.neutral, active, cols, eligible, *((mirror, normal) if mirrored else ()))
    assert (flip is not None) == mirrored
    shapes, image = cell_sums(field, rows, cols, preimages, eligible, cells, flip)
    return SimpleNamespace(
        norms=norms,
        mirror=mirror,
        eligible=eligible,
        rows=rows,
        cols=cols,
        field=field,
        own=row_sums(rows, field.lengths, rig.n_shapes),
        image_own=mirrored_lengths(rows, cols, field.lengths, preimages, rig.n_shapes),
        image=image,
        shapes=shapes,
        flip=flip,
    )


def test_floors_of_the_candidate_bounds_are_below_the_exact_scores(female):
    """Each candidate's floor ``(numerator - slack) / shared`` is at most its eq. 9 error, and the film
    layout's candidates are mostly scored only in part."""
    found = candidate_pairs(
        female.field,
        female.rows,
        female.shapes,
        female.image,
        female.eligible,
        female.norms.max(axis=1),
        0.4,
        female.flip,
    )
    overlap, summed = symmetry._pair_sums(female.field, female.cols, female.mirror, found.first, found.second)
    error = np.where(
        overlap > 0, (female.own[found.first] + female.image_own[found.second] + summed) / overlap, np.inf
    )
    slack = symmetry.BOUND_SLACK * (female.own[found.first] + female.image_own[found.second])
    floor = (found.numerator - slack) / found.shared
    assert found.first.size > 100 and np.all(floor <= error)
    assert np.all(overlap <= found.shared)


def test_self_candidates_keep_every_self_symmetric_shape(female):
    """The bounds for ``m = k`` never rule out a shape whose exact ``eps_kk`` passes eq. 10, and rule out
    most of the others."""
    largest = female.norms.max(axis=1)
    kept = self_candidates(female.field, female.rows, female.shapes, female.image, largest, 0.4)
    every = symmetry._self_errors(
        female.field,
        female.rows,
        female.cols,
        female.mirror,
        np.flatnonzero(female.eligible),
        female.own + female.image_own,
    )
    self_symmetric = female.eligible & (every < 0.4 * largest)
    assert self_symmetric.any() and not (self_symmetric & ~kept).any()
    assert (kept & female.eligible).sum() < 0.5 * female.eligible.sum()


def test_an_involution_probes_one_direction_and_scores_both(female, monkeypatch):
    """On a symmetric mesh the mirror map is an involution: scoring each pair from its smaller shape gives
    the scores of probing both directions, up to rounding, with half the probes."""
    assert symmetry.is_involution(female.mirror)
    found = candidate_pairs(
        female.field,
        female.rows,
        female.shapes,
        female.image,
        female.eligible,
        female.norms.max(axis=1),
        0.4,
        female.flip,
    )
    upper = found.first < found.second
    first, second = found.first[upper], found.second[upper]
    arguments = (female.field, female.cols, female.mirror, female.own, female.image_own, first, second)
    probed: list[int] = []
    pair_sums = symmetry._pair_sums

    def counted(field, cols, mirror, k, m):
        probed.append(k.size)
        return pair_sums(field, cols, mirror, k, m)

    monkeypatch.setattr(symmetry, "_pair_sums", counted)
    shared = symmetry._scores(*arguments)
    monkeypatch.setattr(symmetry, "is_involution", lambda mirror: False)
    both = symmetry._scores(*arguments)
    assert probed == [first.size, 2 * first.size]
    finite = np.isfinite(both)
    assert finite.sum() > 100 and np.array_equal(np.isfinite(shared), finite)
    scale = female.own.max()
    np.testing.assert_allclose(shared[finite], both[finite], rtol=1e-9, atol=1e-12 * scale)


@pytest.mark.parametrize(
    ("mirror", "expected"),
    [
        ([1, 0, 2, -1], True),
        ([-1, -1], True),
        ([1, 2, 0], False),  # a cycle of three
        ([1, 0, 1], False),  # a shared image
        ([1, -1], False),  # the mirror of a vertex without one
    ],
)
def test_involutions_are_told_from_other_mirror_maps(mirror, expected):
    assert symmetry.is_involution(np.array(mirror)) is expected


def test_an_involution_probes_half_of_each_self_symmetric_shape(female, monkeypatch):
    """``eps_kk`` from the vertices ``n <= mirror(n)`` (the others counted twice) equals probing them all."""
    shapes = np.flatnonzero(female.eligible)
    arguments = (female.field, female.rows, female.cols, female.mirror, shapes, female.own + female.image_own)
    probed: list[int] = []
    image_entries = SymmetryField.image_entries

    def counted(field, queried, vertices, mirror):
        probed.append(vertices.size)
        return image_entries(field, queried, vertices, mirror)

    monkeypatch.setattr(SymmetryField, "image_entries", counted)
    halved = symmetry._self_errors(*arguments)
    half = sum(probed)
    monkeypatch.setattr(symmetry, "is_involution", lambda mirror: False)
    whole = symmetry._self_errors(*arguments)
    assert 0.4 < half / (sum(probed) - half) < 0.6
    finite = np.isfinite(whole)
    assert finite.sum() > 10 and np.array_equal(np.isfinite(halved), finite)
    np.testing.assert_allclose(halved[finite], whole[finite], rtol=1e-9, atol=1e-12 * female.own.max())


def test_bounds_over_mirror_cells_equal_those_over_every_cell():
    """Visiting only the cells c <= flip(c) and adding both directions gives each pair the bounds of visiting
    every cell with the image's sums taken from the preimages (the same cells), up to rounding."""
    rig = rigs.generate("female")
    norms, masks, mirror, normal, eligible, _ = inputs(rig)
    active = sparse_masks(masks)
    rows, cols = entries(active)
    field = SymmetryField.of(rig.deltas, norms, active, rows, cols, normal)
    preimages = Preimages.of(mirror, cols)
    cells, flip = vertex_cells(rig.neutral, active, cols, eligible, mirror, normal)
    largest = norms.max(axis=1)
    halved = candidate_pairs(
        field,
        rows,
        *cell_sums(field, rows, cols, preimages, eligible, cells, flip),
        eligible,
        largest,
        0.4,
        flip,
    )
    every = candidate_pairs(
        field, rows, *cell_sums(field, rows, cols, preimages, eligible, cells), eligible, largest, 0.4
    )
    assert halved.first.size > 100
    assert np.array_equal(halved.first, every.first) and np.array_equal(halved.second, every.second)
    assert np.array_equal(halved.shared, every.shared)
    np.testing.assert_allclose(halved.numerator, every.numerator, rtol=1e-9, atol=1e-12 * float(norms.max()))
