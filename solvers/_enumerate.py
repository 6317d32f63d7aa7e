"""Kernels of a few items solved exactly by listing every packing: no backend, no model to build.

Along an expression sequence most kernels left by the exact reductions (`solvers._reduce`) are empty or hold
a handful of items (on a 1,000-shape film sequence, two thirds of its problems have at most ten). Building a
backend's model and starting its search costs milliseconds each time, while the packings of ten items
number at most 1,024 and are listed in a few numpy operations: the packings of the first i items that leave
room for item i (no member conflicts with it, the cap of sec. 6 still allows its shapes) each give one more.
The best of them by eq. 3a is the optimum, proved by the listing itself.
"""

from __future__ import annotations

import numpy as np

#: Kernels of at most this many items are solved by enumeration (at most 2**16 packings to list).
ENUMERATION_MAX_ITEMS = 16


def enumerated_optimum(
    weights: np.ndarray, counts: np.ndarray, cap: int | None, conflicts: np.ndarray
) -> tuple[int, ...]:
    """The packing of largest weight among all packings of at most `ENUMERATION_MAX_ITEMS` items.

    Parameters
    ----------
    weights, counts : (K,) arrays
        Item weights (eq. 3a) and blendshapes per item (the cap row's coefficients).
    cap : int or None
        At most this many blendshapes (sec. 6); None for no cap.
    conflicts : (K, K) bool array
        Items i != j that may not be packed together (the diagonal is ignored).

    Returns
    -------
    tuple of int
        The items, ascending; of equal objectives the packing listed first (by the sums in item order)
        wins.

    Notes
    -----
    O(P K) for the P <= 2**K packings: packing ``p`` is the bit mask of its items, listed with its weight
    and shape count as each item is considered.
    """
    n_items = weights.size
    if n_items > ENUMERATION_MAX_ITEMS:
        raise ValueError(f"enumeration takes at most {ENUMERATION_MAX_ITEMS} items, got {n_items}")
    powers = np.left_shift(1, np.arange(n_items, dtype=np.int64))
    blocked = (conflicts & ~np.eye(n_items, dtype=bool)) @ powers  # the items each item conflicts with
    masks = np.zeros(1, dtype=np.int64)
    values = np.zeros(1, dtype=np.float64)
    shapes = np.zeros(1, dtype=np.int64)
    for item in range(n_items):
        room = (masks & blocked[item]) == 0
        if cap is not None:
            room &= shapes + counts[item] <= cap
        masks = np.concatenate([masks, masks[room] | powers[item]])
        values = np.concatenate([values, values[room] + weights[item]])
        shapes = np.concatenate([shapes, shapes[room] + counts[item]])
    best = int(masks[np.argmax(values)])
    return tuple(item for item in range(n_items) if best >> item & 1)
