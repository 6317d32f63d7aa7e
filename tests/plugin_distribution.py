"""Solver plugins registered the way an installed distribution registers them, for the tests.

A folder on ``sys.path`` holding ``NAME-0.0.dist-info`` (``METADATA`` and ``entry_points.txt``) is what
``importlib.metadata`` finds for an installed package, so the harness discovers its plugins exactly as it
would a third party's, without installing anything.
"""

from __future__ import annotations

import shutil
from collections.abc import Iterator
from pathlib import Path

import pytest

import solvers


def write_distribution(site: Path, module: str, entry_points: str) -> Path:
    """Write the dist-info of a distribution named after ``module`` (its entry points as given) into
    ``site``, made if missing; returns ``site``."""
    name = module.replace("_", "-")
    info = site / f"{module}-0.0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.0\n")
    (info / "entry_points.txt").write_text(entry_points)
    return site


def registered_module(
    source: Path, entry_points: str, site: Path, monkeypatch: pytest.MonkeyPatch
) -> Iterator[None]:
    """Register the plugins of the module file ``source`` for this process and the harness's worker
    processes (``PYTHONPATH``) until the generator is closed; for a fixture to ``yield from``."""
    write_distribution(site, source.stem, entry_points)
    shutil.copy(source, site)
    monkeypatch.syspath_prepend(str(site))
    monkeypatch.setenv("PYTHONPATH", str(site))
    solvers.refresh()
    yield
    solvers.refresh()
