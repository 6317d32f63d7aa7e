"""Content digests of arrays: the keys under which work on equal rigs is memoised per process.

`transfer._setup` and `transfer._scan` key their memos on what the arrays hold, not on which objects they
are, so an equal rig built again shares the work. Hashing a film-sized rig's deltas costs tens of
milliseconds per call, so the digest of an array nobody can write to (read-only down to the buffer that
owns its data, as every `rigs.Rig` array built in memory is) is kept while that array lives.
"""

from __future__ import annotations

import hashlib
import threading
import weakref

import numpy as np

_known: dict[int, tuple[weakref.ref, bytes]] = {}
_known_lock = threading.Lock()


def content_digest(*arrays: np.ndarray) -> str:
    """Hex BLAKE2 digest of the arrays' dtypes, shapes and bytes, in order."""
    digest = hashlib.blake2b(digest_size=16)
    for array in arrays:
        digest.update(_array_digest(np.asarray(array)))
    return digest.hexdigest()


def _array_digest(array: np.ndarray) -> bytes:
    """The digest of one array, kept by identity for an array that cannot change."""
    if not _immutable(array):
        return _hashed(array)
    key = id(array)
    with _known_lock:
        entry = _known.get(key)
    if entry is not None and entry[0]() is array:
        return entry[1]
    found = _hashed(array)
    with _known_lock:
        _known[key] = (weakref.ref(array, lambda _, key=key: _known.pop(key, None)), found)
    return found


def _hashed(array: np.ndarray) -> bytes:
    contiguous = np.ascontiguousarray(array)
    digest = hashlib.blake2b(f"{contiguous.dtype}{contiguous.shape}".encode(), digest_size=16)
    digest.update(contiguous.data)
    return digest.digest()


def _immutable(array: np.ndarray) -> bool:
    """Whether the array and every array it views are read-only, down to one that owns its data."""
    base: object = array
    while isinstance(base, np.ndarray):
        if base.flags.writeable:
            return False
        base = base.base
    return base is None
