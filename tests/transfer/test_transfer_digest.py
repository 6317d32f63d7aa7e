"""Content digests: equal arrays share one; a digest is remembered only for an array that cannot change."""

from __future__ import annotations

import numpy as np

from transfer import _digest
from transfer._digest import content_digest


def frozen(array: np.ndarray) -> np.ndarray:
    array = np.array(array)
    array.flags.writeable = False
    return array


def test_the_digest_follows_content_dtype_and_shape():
    values = np.arange(12.0)
    assert content_digest(values) == content_digest(values.copy())
    assert content_digest(values) != content_digest(values.astype(np.float32))
    assert content_digest(values) != content_digest(values.reshape(3, 4))
    assert content_digest(values, values) != content_digest(values)


def test_a_read_only_array_is_hashed_once_and_forgotten_with_it(monkeypatch):
    calls = []
    hashed = _digest._hashed
    monkeypatch.setattr(_digest, "_hashed", lambda array: calls.append(1) or hashed(array))
    array = frozen(np.arange(6.0))
    first = content_digest(array)
    assert content_digest(array) == first and len(calls) == 1
    key = id(array)
    del array
    assert key not in _digest._known


def test_an_array_that_can_change_is_hashed_every_time():
    owner = np.arange(6.0)
    view = owner[:]
    view.flags.writeable = False  # read-only, but its owner is not
    before = content_digest(view), content_digest(owner)
    owner[0] = 7.0
    assert content_digest(view) != before[0] and content_digest(owner) != before[1]
