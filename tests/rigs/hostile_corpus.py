"""The registry of the hostile-input corpus: each case module (`tests/rigs/hostile_*.py`) adds its malformed
inputs to `CASES`, which `tests/rigs/test_hostile_inputs.py` loads under its guards."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import rigs

#: Seconds one load may take before the guard calls it a hang.
HANG_SECONDS = 20
#: Peak memory one load may take.
PEAK_BYTES = 2**30


@dataclass(frozen=True)
class Case:
    """One malformed input: ``build(folder)`` writes it and returns the path to load (and options).

    ``error`` is the pattern the RigError must match; with ``warning`` instead, the input loads with a
    RigWarning matching it and ``check(rig)`` holds.
    """

    name: str
    build: Callable[[Path], tuple[Path, dict]]
    error: str | None = None
    warning: str | None = None
    check: Callable[[rigs.Rig], bool] = field(default=lambda rig: True)
    heavy: bool = False


CASES: list[Case] = []


def case(name: str, error: str | None = None, **kwargs) -> Callable:
    """Register the decorated builder as a corpus case."""

    def register(build: Callable[[Path], tuple[Path, dict]]) -> Callable:
        CASES.append(Case(name, build, error, **kwargs))
        return build

    return register


def add(name: str, build: Callable[[Path], tuple[Path, dict]], error: str | None = None, **kwargs) -> None:
    CASES.append(Case(name, build, error, **kwargs))
