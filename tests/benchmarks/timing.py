"""Timing of the benchmarks: the best of a few repetitions, so that a busy machine does not miss a target by
chance (see ``conftest.speed_target``)."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TypeVar

Result = TypeVar("Result")


def best_time(function: Callable[[], Result], repeats: int) -> tuple[float, Result]:
    """Time ``repeats`` calls of ``function``.

    Parameters
    ----------
    function : callable
        Called with no arguments.
    repeats : int
        Calls to time (at least 1).

    Returns
    -------
    tuple of float and the result
        The fewest seconds of one call, and the last call's result.
    """
    if repeats < 1:
        raise ValueError(f"repeats must be at least 1, got {repeats}")
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        result = function()
        times.append(time.perf_counter() - start)
    return min(times), result
