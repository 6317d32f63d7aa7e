"""Built-in solver plugins as the tests compare them: available or skipped, one ability switched off."""

from __future__ import annotations

from typing import Any

import pytest

import solvers
from solvers import LoadedSolver


def available(name: str) -> LoadedSolver:
    """The plugin ``name``, loaded; the test is skipped where its backend is not installed."""
    loaded = solvers.get(name)
    if not loaded.availability():
        pytest.skip(f"{name} is not available here")
    return loaded


def variant(name: str, label: str, **attributes: Any) -> LoadedSolver:
    """The plugin ``name`` (`available`) with class ``attributes`` replaced, e.g.
    ``variant("cpsat", "Unfixed", _fixes_by_reduced_costs=False)``; ``label`` ends its class name."""
    plugin = type(available(name).plugin)
    return solvers.load(type(f"{plugin.__name__}{label}", (plugin,), attributes))
