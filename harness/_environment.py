"""Where and with what a run ran: package and backend versions, git commit, machine (for ``run.json``)."""

from __future__ import annotations

import importlib.metadata
import os
import platform
import socket
import subprocess
import sys
from pathlib import Path

#: Distributions whose versions every run records (solver backends included; missing ones record None).
DISTRIBUTIONS: tuple[str, ...] = (
    "expression-packing-harness",
    "numpy",
    "scipy",
    "networkx",
    "pandas",
    "pyarrow",
    "pulp",
    "cbcbox",
    "ortools",
    "highspy",
    "mip",
    "pyscipopt",
    "dask",
    "distributed",
)


def versions() -> dict[str, str | None]:
    """Python and installed distribution versions, without importing any of them."""
    found: dict[str, str | None] = {"python": platform.python_version()}
    for name in DISTRIBUTIONS:
        try:
            found[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            found[name] = None
    return found


def git_state(directory: Path | None = None) -> dict[str, str | bool | None]:
    """Commit and dirtiness of the git checkout holding the harness package (None outside a checkout)."""
    directory = directory or Path(__file__).resolve().parent

    def git(*args: str) -> str | None:
        try:
            done = subprocess.run(
                ["git", *args], cwd=directory, capture_output=True, text=True, timeout=10, check=True
            )
        except (OSError, subprocess.SubprocessError):
            return None
        return done.stdout.strip()

    commit = git("rev-parse", "HEAD")
    status = git("status", "--porcelain") if commit else None
    return {"commit": commit, "dirty": None if status is None else bool(status)}


def machine() -> dict[str, str | int | None]:
    """Host name, platform, processor and core count."""
    return {
        "hostname": socket.gethostname(),
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpu_count": os.cpu_count(),
        "python": sys.version.split()[0],
    }
