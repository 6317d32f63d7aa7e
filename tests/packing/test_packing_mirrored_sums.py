"""The per-cell sums of the mirrored masks (`packing._symmetry_candidates.cell_sums`) and their summed lengths
(`packing._symmetry_field.mirrored_lengths`) against the definition of ``p(b_m)^n = b_m^{mirror(n)}`` and
``P_m^n = R dv_m^{mirror(n)}`` (eq. 9), for one-to-one mirror maps with and without unmirrored vertices and
for maps with shared images."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from packing import _symmetry_candidates as symmetry_candidates
from packing._symmetry_candidates import cell_sums, vertex_cells
from packing._symmetry_field import Preimages, SymmetryField, compact_entries, mirrored_lengths

N_SHAPES, N_VERTICES, N_CELLS = 6, 40, 5


def _mirror(kind: str, rng: np.random.Generator) -> np.ndarray:
    mirror = rng.permutation(N_VERTICES)
    if kind == "unmirrored":
        mirror[rng.choice(N_VERTICES, 9, replace=False)] = -1
    elif kind == "shared images":
        mirror[:6] = mirror[6:12]
        mirror[12] = -1
        mirror[20:23] = mirror[30]  # four preimages of one vertex
    return mirror


def _case(kind: str, seed: int) -> tuple[np.ndarray, np.ndarray, sp.csr_matrix, np.ndarray, SymmetryField]:
    rng = np.random.default_rng(seed)
    mirror = _mirror(kind, rng)
    masks = rng.random((N_SHAPES, N_VERTICES)) < 0.4
    masks[0] = False  # a shape without active vertices
    deltas = rng.normal(size=(N_SHAPES, N_VERTICES, 3))
    active = sp.csr_matrix(masks)
    active.sort_indices()
    normal = rng.normal(size=3)
    normal /= np.linalg.norm(normal)
    field = SymmetryField.of(deltas, np.linalg.norm(deltas, axis=2), active, *compact_entries(active), normal)
    return deltas, masks, active, mirror, field


KINDS = ["bijection", "unmirrored", "shared images"]


@pytest.mark.parametrize("kind", KINDS)
def test_preimages_list_every_mirrored_entry_once(kind):
    """The first preimage of each vertex and the further (entry, preimage) pairs together are the mirrored
    entries: each (m, n) with ``b_m^{mirror(n)}`` exactly once."""
    _, masks, active, mirror, _ = _case(kind, 5)
    rows, cols = compact_entries(active)
    preimages = Preimages.of(mirror, cols)
    assert np.array_equal(preimages.counts, np.bincount(mirror[mirror >= 0], minlength=N_VERTICES))
    for vertex in range(N_VERTICES):
        sources = np.flatnonzero(mirror == vertex)
        assert preimages.first[vertex] == (sources[0] if sources.size else -1)
    found = [
        (int(rows[e]), int(preimages.first[cols[e]]))
        for e in range(rows.size)
        if preimages.first[cols[e]] >= 0
    ]
    found += list(zip(rows[preimages.extra_entry].tolist(), preimages.extra_preimage.tolist(), strict=True))
    expected = [
        (m, n) for m in range(N_SHAPES) for n in range(N_VERTICES) if mirror[n] >= 0 and masks[m, mirror[n]]
    ]
    assert sorted(found) == expected
    assert (preimages.extra_entry.size > 0) == (kind == "shared images")


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cell_sums_follow_their_definition(kind, seed):
    """``A_kc``, ``a_kc``, ``P_mc`` and ``p_mc`` per (cell, shape) present, and ``|b_k|`` and ``|p(b_m)|``,
    against dense (K, N) arrays."""
    deltas, masks, active, mirror, field = _case(kind, seed)
    rows, cols = compact_entries(active)
    cell = np.random.default_rng(seed + 10).integers(0, N_CELLS, N_VERTICES)
    cell[cell == N_CELLS - 1] = 0  # (a cell number no vertex has, below the largest)
    cell[-1] = N_CELLS - 1
    selected = np.ones(N_SHAPES, dtype=bool)
    selected[3] = False
    shapes, image = cell_sums(field, rows, cols, Preimages.of(mirror, cols), selected, cell)

    valid = mirror >= 0
    mirrored_masks = masks[:, np.where(valid, mirror, 0)] & valid  # p(b_m)^n
    mirrored_moves = deltas[:, np.where(valid, mirror, 0)] @ field.reflection  # P_m^n
    for sums, masks_of, moves, totals in (
        (shapes, masks, deltas, masks.sum(axis=1)),
        (image, mirrored_masks, mirrored_moves, mirrored_masks.sum(axis=1)),
    ):
        keys, expected_sums, expected_counts = [], [], []
        for c in range(N_CELLS):
            for k in np.flatnonzero(selected):
                inside = masks_of[k] & (cell == c)
                if inside.any():
                    keys.append(c * N_SHAPES + k)
                    expected_counts.append(int(inside.sum()))
                    expected_sums.append(moves[k, inside].sum(axis=0))
        assert sums.present.tolist() == keys
        assert sums.counts.tolist() == expected_counts
        np.testing.assert_allclose(sums.sums, np.reshape(expected_sums, (-1, 3)), rtol=1e-12, atol=1e-12)
        assert sums.totals.tolist() == totals.tolist()


@pytest.mark.parametrize("kind", KINDS)
def test_mirrored_lengths_count_each_mirrored_entry(kind):
    """``sum_n |p(b_m)^n P_m^n|``: each active length once per preimage of its vertex."""
    deltas, masks, active, mirror, field = _case(kind, 7)
    rows, cols = compact_entries(active)
    found = mirrored_lengths(rows, cols, field.lengths, Preimages.of(mirror, cols), N_SHAPES)
    valid = mirror >= 0
    image = np.where(valid, mirror, 0)
    by_definition = (np.linalg.norm(deltas[:, image], axis=2) * (masks[:, image] & valid)).sum(axis=1)
    np.testing.assert_allclose(found, by_definition, rtol=1e-12)


def _involution(rng: np.random.Generator) -> np.ndarray:
    """Pairs of vertices swapped, a few vertices their own mirror, a few pairs without one."""
    order = rng.permutation(N_VERTICES)
    mirror = np.arange(N_VERTICES)
    pairs = order[:30].reshape(-1, 2)
    mirror[pairs[:, 0]], mirror[pairs[:, 1]] = pairs[:, 1], pairs[:, 0]
    mirror[order[30:34]] = -1
    return mirror


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
@pytest.mark.parametrize("with_neutral", [True, False])
def test_mirror_cells_are_images_of_each_other(seed, with_neutral):
    """For an involutive map, ``cell(mirror(n)) = flip(cell(n))``, flip is an involution on the cells, and
    the farther and the nearer vertices of the pairs (along the normal) never share a cell; any other map
    gets no mirror cells."""
    rng = np.random.default_rng(seed)
    mirror = _involution(rng)
    neutral = rng.normal(size=(N_VERTICES, 3)) if with_neutral else None
    active = sp.csr_matrix(rng.random((N_SHAPES, N_VERTICES)) < 0.4)
    active.sort_indices()
    _, cols = compact_entries(active)
    normal = np.array([1.0, 0.0, 0.0])
    cell, flip = vertex_cells(neutral, active, cols, np.ones(N_SHAPES, dtype=bool), mirror, normal)
    mirrored = np.flatnonzero(mirror >= 0)
    assert np.array_equal(cell[mirror[mirrored]], flip[cell[mirrored]])
    assert np.all(flip[cell[mirror < 0]] == -1)
    kept = flip >= 0
    assert np.array_equal(flip[flip[kept]], np.flatnonzero(kept))
    if with_neutral:  # each cell holds only the farther or only the nearer vertices of their pairs
        pairs = mirrored[mirror[mirrored] != mirrored]
        farther = neutral[pairs, 0] > neutral[mirror[pairs], 0]
        assert not set(cell[pairs[farther]].tolist()) & set(cell[pairs[~farther]].tolist())
    assert (
        vertex_cells(neutral, active, cols, np.ones(N_SHAPES, dtype=bool), _mirror("bijection", rng))[1]
        is None
    )


@pytest.mark.parametrize("with_neutral", [True, False])
@pytest.mark.parametrize("budget", [1, 2, 3])
def test_a_budget_below_the_four_sides_stops_at_one_grid_cell(monkeypatch, with_neutral, budget):
    """A budget of fewer (cell, shape) sums than the four sides of one grid cell ends the coarsening at a
    single grid cell (its placed, image, on-plane and unmirrored vertices: four cells) instead of looping."""
    rng = np.random.default_rng(5)
    mirror = _involution(rng)  # all four sides present
    neutral = rng.normal(size=(N_VERTICES, 3)) if with_neutral else None
    active = sp.csr_matrix(rng.random((N_SHAPES, N_VERTICES)) < 0.4)
    active.sort_indices()
    _, cols = compact_entries(active)
    monkeypatch.setattr(symmetry_candidates, "MAX_CELL_SUMS", budget * N_SHAPES)
    cell, flip = vertex_cells(neutral, active, cols, np.ones(N_SHAPES, dtype=bool), mirror, np.eye(3)[0])
    assert cell.max() + 1 == 4 and sorted(flip.tolist()) == [-1, 0, 1, 2]
    mirrored = np.flatnonzero(mirror >= 0)
    assert np.array_equal(cell[mirror[mirrored]], flip[cell[mirrored]])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_mirror_cell_sums_equal_the_sums_over_the_preimages(seed):
    """With mirror cells, the image's sums taken from the shapes' sums under the mirror cells are those summed
    from each active entry's preimages over the same cells."""
    rng = np.random.default_rng(seed)
    mirror = _involution(rng)
    masks = rng.random((N_SHAPES, N_VERTICES)) < 0.4
    deltas = rng.normal(size=(N_SHAPES, N_VERTICES, 3))
    active = sp.csr_matrix(masks)
    active.sort_indices()
    rows, cols = compact_entries(active)
    normal = rng.normal(size=3)
    normal /= np.linalg.norm(normal)
    field = SymmetryField.of(deltas, np.linalg.norm(deltas, axis=2), active, rows, cols, normal)
    selected = rng.random(N_SHAPES) < 0.8
    neutral = rng.normal(size=(N_VERTICES, 3))
    cell, flip = vertex_cells(neutral, active, cols, selected, mirror, normal)
    preimages = Preimages.of(mirror, cols)
    shapes, image = cell_sums(field, rows, cols, preimages, selected, cell, flip)
    direct_shapes, direct_image = cell_sums(field, rows, cols, preimages, selected, cell)
    for found, direct in ((shapes, direct_shapes), (image, direct_image)):
        assert found.present.tolist() == direct.present.tolist()
        assert found.counts.tolist() == direct.counts.tolist()
        assert found.totals.tolist() == direct.totals.tolist()
        np.testing.assert_allclose(found.sums, direct.sums, rtol=1e-12, atol=1e-12)
