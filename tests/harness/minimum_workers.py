"""Functions the worker of ``harness pack --minimum`` runs in place of
`session._minimum.ordered_cover` (named by `session._minimum.SOLVE_IN_WORKER`), for the
tests."""

from __future__ import annotations

import os
import threading
from dataclasses import replace
from pathlib import Path

from packing import PackingProblem, Termination
from session._minimum import ordered_cover
from solvers import OrderedSequence

#: Environment variable naming the file `stalling_cover` writes its process id to.
MARK_VARIABLE = "HARNESS_TEST_MINIMUM_MARK"


def unproven_cover(problem: PackingProblem, time_limit: float, seed: int) -> OrderedSequence:
    """The ordered cover, with a lower bound one below its count, as when the proof ran out of time."""
    ordered = ordered_cover(problem, time_limit, seed)
    minimum = ordered.minimum
    minimum = replace(minimum, lower_bound=minimum.count - 1, termination=Termination.TIME_LIMIT)
    return replace(ordered, minimum=minimum)


def aborting_cover(problem: PackingProblem, time_limit: float, seed: int) -> OrderedSequence:
    """Crashes the process, as a segfaulting backend would."""
    os.abort()


def raising_cover(problem: PackingProblem, time_limit: float, seed: int) -> OrderedSequence:
    """Fails as a backend error would."""
    raise RuntimeError("the colouring model is corrupt")


def stalling_cover(problem: PackingProblem, time_limit: float, seed: int) -> OrderedSequence:
    """Writes its process id to the mark file, then never answers."""
    Path(os.environ[MARK_VARIABLE]).write_text(str(os.getpid()))
    threading.Event().wait()
    raise AssertionError("unreachable")
