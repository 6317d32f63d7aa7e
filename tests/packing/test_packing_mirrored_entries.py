"""The entries of the mirrored masks (`packing._symmetry_field.mirrored_entries`) against their definition,
for one-to-one mirror maps with and without unmirrored vertices and for a map with shared images."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from packing._symmetry_field import compact_entries, mirrored_entries


def _expected(active: sp.csr_matrix, mirror: np.ndarray) -> tuple[list[int], list[int], list[int]]:
    """Shape by shape, its active vertices v from the last, each with its preimages n (``mirror(n) = v``)
    ascending: the entry (m, n) and the position of the active entry (m, v)."""
    rows, cols, source = [], [], []
    for m in range(active.shape[0]):
        for position in range(active.indptr[m + 1] - 1, active.indptr[m] - 1, -1):
            for n in np.flatnonzero(mirror == active.indices[position]).tolist():
                rows.append(m)
                cols.append(n)
                source.append(position)
    return rows, cols, source


@pytest.mark.parametrize("kind", ["bijection", "unmirrored", "shared images"])
@pytest.mark.parametrize("chunk", [None, 7])
def test_mirrored_entries_follow_their_definition(monkeypatch, kind, chunk):
    if chunk is not None:  # runs of a few shapes
        monkeypatch.setattr("packing._symmetry_field.ENTRY_CHUNK", chunk)
    rng = np.random.default_rng(5)
    n_vertices = 40
    mirror = rng.permutation(n_vertices)
    if kind == "unmirrored":
        mirror[rng.choice(n_vertices, 9, replace=False)] = -1
    elif kind == "shared images":
        mirror[:6] = mirror[6:12]
        mirror[12] = -1
    active = sp.csr_matrix(rng.random((6, n_vertices)) < 0.3)
    active.sort_indices()
    rows, cols = compact_entries(active)
    found = mirrored_entries(active, rows, cols, mirror)
    assert [values.tolist() for values in found] == list(_expected(active, mirror))
