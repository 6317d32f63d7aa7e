"""Solver plugins registered the way an installed distribution registers them, for the tests.

A folder on ``sys.path`` holding ``NAME-0.0.dist-info`` (``METADATA`` and ``entry_points.txt``) is what
``importlib.metadata`` finds for an installed package, so the harness discovers its plugins exactly as it
would a third party's, without installing anything. Where the installation itself is under test,
`fresh_environment` makes a new virtual environment to ``pip install`` a plugin into, offline.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import sysconfig
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


def fresh_environment(folder: Path) -> Path:
    """A new virtual environment without packages of its own, which sees this environment's packages
    through a site directory; returns its interpreter."""
    subprocess.run([sys._base_executable, "-m", "venv", "--without-pip", str(folder)], check=True)
    python = folder / "bin" / "python"
    purelib = subprocess.run(
        [python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        check=True,
        capture_output=True,
        text=True,
    ).stdout.strip()
    ours = sysconfig.get_paths()["purelib"]
    (Path(purelib) / "outer_environment.pth").write_text(f"import site; site.addsitedir({ours!r})\n")
    return python


def run_in(python: Path, *arguments: str, cwd: Path) -> subprocess.CompletedProcess:
    """Run ``python`` (e.g. a `fresh_environment`'s) with ``arguments`` in ``cwd``, output captured."""
    return subprocess.run(
        [str(python), *arguments], cwd=cwd, capture_output=True, text=True, timeout=300, check=False
    )


#: ``pip install`` into an environment without fetching anything (the build backend is the environment's).
OFFLINE_INSTALL = ("-m", "pip", "install", "--quiet", "--no-deps", "--no-build-isolation", "--no-index")
