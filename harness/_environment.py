"""Where and with what a run ran: package and backend versions, git commit, machine (for ``run.json``)."""

from __future__ import annotations

import hashlib
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


def _git(*args: str, directory: Path | None = None) -> str | None:
    """Output of a git command in the checkout holding the harness package, or None when it fails."""
    try:
        done = subprocess.run(
            ["git", *args],
            cwd=directory or Path(__file__).resolve().parent,
            capture_output=True,
            text=True,
            timeout=10,
            check=True,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return done.stdout.strip()


def git_state(directory: Path | None = None, *, output: Path | None = None) -> dict[str, str | bool | None]:
    """Commit and dirtiness of the git checkout holding the harness package (None outside a checkout).

    Files under ``output`` (the run's own folder, e.g. a baseline committed in the checkout) do not make the
    tree dirty: the run is writing them.
    """
    commit = _git("rev-parse", "HEAD", directory=directory)
    if not commit:
        return {"commit": None, "dirty": None}
    pathspec = []
    top = _git("rev-parse", "--show-toplevel", directory=directory)
    if output is not None and top and Path(output).resolve().is_relative_to(Path(top).resolve()):
        pathspec = ["--", ":/", f":(top,exclude){Path(output).resolve().relative_to(Path(top).resolve())}"]
    status = _git("status", "--porcelain", *pathspec, directory=directory)
    return {"commit": commit, "dirty": None if status is None else bool(status)}


def commits_since(commit: str, directory: Path | None = None) -> int | None:
    """How many commits HEAD of the harness's checkout is ahead of ``commit``: 0 at it, None when
    ``commit`` is not an ancestor of HEAD (another branch, rewritten history) or there is no checkout."""
    if not commit or _git("merge-base", "--is-ancestor", commit, "HEAD", directory=directory) is None:
        return None
    count = _git("rev-list", "--count", f"{commit}..HEAD", directory=directory)
    return None if count is None else int(count)


def machine() -> dict[str, str | int | None]:
    """Host name, platform, processor, its model name (None where the system does not say) and core count."""
    return {
        "hostname": socket.gethostname(),
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpu_model": _cpu_model(),
        "cpu_count": os.cpu_count(),
        "python": sys.version.split()[0],
    }


def _cpu_model() -> str | None:
    """The processor's model name from ``/proc/cpuinfo`` (Linux) with a digest of its feature flags (virtual
    machines often name only "Intel(R) Xeon(R) Processor"; the flags tell AVX-512 hosts from others), else
    None."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as info:
            fields = dict(line.partition(":")[::2] for line in info.read().split("\n\n")[0].splitlines())
    except OSError:
        return None
    fields = {key.strip(): value.strip() for key, value in fields.items()}
    model = fields.get("model name") or fields.get("Processor") or fields.get("cpu model")
    if not model:
        return None
    flags = fields.get("flags") or fields.get("Features")
    return f"{model} (flags {hashlib.sha256(flags.encode()).hexdigest()[:8]})" if flags else model
