"""Validating a rig's deltas allocates nothing of their size (the film preset's deltas are 480 MB)."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from rigs import Rig, RigError


def _rig_arrays(n_shapes: int = 40, n_vertices: int = 20_000) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    neutral = np.random.default_rng(0).normal(size=(n_vertices, 3))
    deltas = np.random.default_rng(1).normal(size=(n_shapes, n_vertices, 3))
    return neutral, deltas, np.array([[0, 1, 2]])


def test_validation_allocates_no_array_of_the_deltas_size() -> None:
    neutral, deltas, triangles = _rig_arrays()
    names = [f"s{k}" for k in range(len(deltas))]
    tracemalloc.start()
    try:
        Rig(neutral, deltas, triangles, names)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < deltas.nbytes / 8, f"validation peaked at {peak / 2**20:.1f} MiB"


@pytest.mark.parametrize(
    ("values", "message"),
    [
        ({(3, 7, 1): 1e200, (5, 2, 0): np.nan}, r"'s5' has a non-finite displacement at vertex 2"),
        ({(3, 7, 1): -1e200, (5, 2, 0): 1e300}, r"'s3' has a displacement beyond 1e\+150 at vertex 7"),
        ({(4, 9, 2): -np.inf}, r"'s4' has a non-finite displacement at vertex 9"),
    ],
)
def test_the_first_bad_shape_is_named_non_finite_first(values, message) -> None:
    neutral, deltas, triangles = _rig_arrays(8, 50)
    for index, value in values.items():
        deltas[index] = value
    with pytest.raises(RigError, match=message):
        Rig(neutral, deltas, triangles, [f"s{k}" for k in range(len(deltas))])
