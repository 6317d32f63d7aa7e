"""What the rig-reader tests build their files from: a small grid mesh, and a guard against hangs."""

from __future__ import annotations

import signal
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np

#: Vertices along each side of the flat grid mesh.
SIDE = 4
#: The grid's vertices, row by row, in the plane z = 0.
GRID = np.array([[x, y, 0.0] for y in range(SIDE) for x in range(SIDE)])
#: The grid's quads (0-based vertex indices, counter-clockwise seen from +z).
QUADS = [
    [y * SIDE + x, y * SIDE + x + 1, (y + 1) * SIDE + x + 1, (y + 1) * SIDE + x]
    for y in range(SIDE - 1)
    for x in range(SIDE - 1)
]


@contextmanager
def hang_alarm(seconds: int) -> Iterator[None]:
    """Raise `TimeoutError` in the guarded block when it runs longer than ``seconds`` (SIGALRM)."""

    def hang(signum: int, frame: object) -> None:
        raise TimeoutError(f"rig loading hung for more than {seconds} s")

    previous = signal.signal(signal.SIGALRM, hang)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
