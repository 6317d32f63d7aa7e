"""A full disk as `registry.atomic_write` meets it, for the tests of writing records."""

from __future__ import annotations

import errno
import os
from typing import Any


class FullDisk:
    """The `os` module as `registry.atomic_write` sees it on a full disk: data is written, fsync fails.

    Put it in place of ``registry._atomic.os`` (``monkeypatch.setattr(_atomic, "os", FullDisk())``).
    """

    def __getattr__(self, name: str) -> Any:
        return getattr(os, name)

    @staticmethod
    def fsync(descriptor: int) -> None:
        """Fail as ``os.fsync`` does when the device has no space left."""
        raise OSError(errno.ENOSPC, "No space left on device")
