"""Speed targets for the benchmarks.

A speed target is a hard assertion only in a benchmark run (``--benchmark-enable``, e.g. ``tox -e bench``).
In the default test run the benchmarks execute once as plain tests on a shared, noisy machine: there a
missed target is recorded in ``benchmark.extra_info["targets"]`` and reported as a warning, never a failure.
"""

from __future__ import annotations

import compileall
import warnings
from collections.abc import Callable
from pathlib import Path

import pytest

#: The project's packages.
PACKAGES = ("registry", "rigs", "packing", "solvers", "transfer", "render", "harness", "session", "reports")


class SpeedTargetMissed(UserWarning):
    """A speed target was missed in a run that does not gate on timings."""


@pytest.fixture
def speed_target(benchmark) -> Callable[..., None]:
    """Check ``measured <= limit`` (or ``>=`` with ``at_least=True``) under the rule above."""

    def check(name: str, measured: float, limit: float, *, at_least: bool = False) -> None:
        met = measured >= limit if at_least else measured <= limit
        benchmark.extra_info.setdefault("targets", {})[name] = {
            "measured": measured,
            "limit": limit,
            "at_least": at_least,
            "met": met,
        }
        if met:
            return
        message = f"{name}: measured {measured:.4g}, target {'>=' if at_least else '<='} {limit:.4g}"
        if benchmark.disabled:
            warnings.warn(message, SpeedTargetMissed, stacklevel=2)
        else:
            pytest.fail(message)

    return check


@pytest.fixture(scope="session")
def compiled_project() -> None:
    """The project's packages compiled to bytecode, as installing them does, before a whole-process benchmark
    times fresh ``harness`` processes: under ``PYTHONDONTWRITEBYTECODE`` (set on some CI machines) every
    process would otherwise compile them from source again, which no installed tool does."""
    root = Path(__file__).resolve().parents[2]
    for package in PACKAGES:
        compileall.compile_dir(root / package, quiet=1)
