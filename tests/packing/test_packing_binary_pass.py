"""The one-pass binary blendshapes of the analysis (`packing._binary.active_entries`) against their plain
definition: the lengths of `displacement_norms`, the masks of eq. 2 and the empty shapes, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

import packing._binary as binary


def _deltas(seed: int, n_shapes: int = 9, n_vertices: int = 301) -> np.ndarray:
    """Displacements over many magnitudes (so that the order of the sums of squares shows), with an empty
    shape and a shape below the noise floor."""
    rng = np.random.default_rng(seed)
    deltas = rng.standard_normal((n_shapes, n_vertices, 3)) * 10.0 ** rng.uniform(
        -3, 1, (n_shapes, n_vertices, 1)
    )
    deltas[2] = 0.0
    deltas[5] *= 1e-12
    return deltas


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("blocks", [None, (24 * 301 * 2, 301 * 5)])
def test_active_entries_are_the_dense_lengths_masks_and_displacements(monkeypatch, seed, blocks):
    if blocks is not None:  # several blocks of shapes, the last one short
        monkeypatch.setattr(binary, "LENGTH_BYTES", blocks[0])
        monkeypatch.setattr(binary, "MASK_LENGTHS", blocks[1])
    deltas = _deltas(seed)
    norms = binary.displacement_norms(deltas)
    empty = binary.empty_mask(norms, 1e-6, 10.0)
    masks = binary.masks_from_norms(norms, 0.3, empty)
    lengths, found_empty, active, moved = binary.active_entries(deltas, 0.3, 1e-6, 10.0, gather=True)
    expected = binary.sparse_masks(masks)
    assert np.array_equal(found_empty, empty) and found_empty[[2, 5]].all()
    assert np.array_equal(active.indptr, expected.indptr) and np.array_equal(active.indices, expected.indices)
    assert active.indices.dtype == expected.indices.dtype and active.has_sorted_indices
    assert lengths.data.tobytes() == norms[masks].tobytes()  # bit for bit
    assert np.array_equal(moved, deltas[masks])
    assert binary.active_entries(deltas, 0.3, 1e-6, 10.0)[3] is None


@pytest.mark.parametrize("mu", [0.3, 0.5, 1.0])
def test_entries_at_the_threshold_are_decided_as_eq_2_decides_them(mu):
    """Lengths a few units in the last place around ``mu`` times the largest: only the squares near the
    threshold are rooted, and those decide exactly as the lengths of `displacement_norms` do."""
    rng = np.random.default_rng(7)
    directions = rng.standard_normal((4, 500, 3))
    directions /= binary.displacement_norms(directions)[..., None]
    largest = 10.0 ** rng.uniform(-3, 2, (4, 1, 1))
    ulps = rng.integers(-4, 5, (4, 500, 1)).astype(np.float64)
    deltas = directions * (mu * largest) * (1.0 + ulps * np.finfo(np.float64).eps)
    deltas[:, 0] = directions[:, 0] * largest[:, 0]  # the largest displacement of each shape
    norms = binary.displacement_norms(deltas)
    masks = binary.masks_from_norms(norms, mu, binary.empty_mask(norms, 1e-6, 10.0))
    lengths, _, active, _ = binary.active_entries(deltas, mu, 1e-6, 10.0)
    assert 0 < masks.sum() < masks.size - 4  # (entries on both sides of the threshold)
    assert np.array_equal(active.toarray(), masks)
    assert lengths.data.tobytes() == norms[masks].tobytes()
