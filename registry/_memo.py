"""A bounded, thread-safe memo: the one cache type of the project.

The transfer package keeps set-ups per rig pair, scanners per target, scans per capture session and fitted
expressions per rigging state in one, the harness's cells their rigs and transfer results: at most
``size`` entries, the least recently used dropped first, a value built outside the lock (two threads may
build one key at once; the later value is kept).
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import Generic, TypeVar

Value = TypeVar("Value")


class BoundedMemo(Generic[Value]):
    """At most ``size`` values by key, least recently used dropped first.

    Parameters
    ----------
    size : int
        Entries kept (at least 1).
    """

    def __init__(self, size: int) -> None:
        self.size = max(1, int(size))
        self._items: OrderedDict[Hashable, Value] = OrderedDict()
        self._lock = threading.Lock()

    def __len__(self) -> int:
        return len(self._items)

    def get(self, key: Hashable) -> Value | None:
        """The value kept under ``key`` (now the most recently used), or None."""
        with self._lock:
            if key not in self._items:
                return None
            self._items.move_to_end(key)
            return self._items[key]

    def put(self, key: Hashable, value: Value) -> Value:
        """Keep ``value`` under ``key``, dropping the least recently used beyond ``size``; returns it."""
        with self._lock:
            self._items[key] = value
            self._items.move_to_end(key)
            while len(self._items) > self.size:
                self._items.popitem(last=False)
        return value

    def get_or_build(self, key: Hashable, build: Callable[[], Value]) -> Value:
        """The value under ``key``, built by ``build`` (outside the lock) and kept when missing."""
        found = self.get(key)
        return self.put(key, build()) if found is None else found

    def clear(self) -> None:
        """Forget every value."""
        with self._lock:
            self._items.clear()
