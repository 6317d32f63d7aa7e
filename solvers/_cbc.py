"""The CBC executables PuLP can drive, and CBC's own log (shared by ``cbc-pulp`` and ``naive-pulp-cbc``).

PuLP's bundled CBC is 2.10.3 (2019) and several times slower than the CBC of the ``cbcbox`` wheel (``pip
install pulp[cbc]``; docs/architecture.md), so the newer one is preferred where installed, and the binary that
ran is recorded.
"""

from __future__ import annotations

import functools
import glob
import importlib.util
import os
import platform
import re
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from packing import Termination
from solvers._base import Availability, Stopwatch, distribution_version, package_availability

#: Which CBC executable to run: the newest found, the cbcbox wheel's, or the one bundled with PuLP.
CBC_CHOICES = ("auto", "cbcbox", "bundled")

#: CBC's cutoff increment (``-increment``): once CBC has an incumbent, it only looks for solutions better
#: by this much, and prunes every node whose bound is not, yet still reports the incumbent as *optimal*.
#: Its default is absolute: 1e-4 in the cbcbox CBC and 1e-5 in PuLP's CBC 2.10.3, and the MIP gaps do
#: not override it. cbc-mip answered OPTIMAL 3.8e-5 below the optimum on a 655-item K=2000 problem
#: (docs/architecture.md). Two packings' objectives that matter differ by much less: by the tie-break
#: alone (`packing.tie_break_perturbation`), an exchange of up to three items moves the objective by at
#: least ``1e-5 / (4 (I + 1))`` (1.2e-9 at I = 2000 items), so any increment must be far below 1e-9; 0
#: (a new incumbent must merely be better) makes the gap-0 proof the only stopping rule.
CBC_INCREMENT = 0.0


def objective_scale(weights: np.ndarray) -> float:
    """Factor that makes the largest objective coefficient 1 (1 when every weight is 0).

    CBC's LP tolerances (primal, dual: 1e-7) are absolute. With every weight near 0.01 they are 1e-5 of
    an item's weight, enough to prune the node of the optimum (seen on random 120-item problems); with the
    weights scaled to at most 1, they are again far below the tie-break (1e-9). Bounds read back are
    divided by the same factor.
    """
    largest = float(np.abs(weights).max()) if np.size(weights) else 0.0
    return 1.0 / largest if largest > 0 else 1.0


@dataclass(frozen=True)
class CbcBinary:
    """A CBC executable and where it comes from (``cbcbox`` or ``bundled``)."""

    path: str
    origin: str

    @property
    def version(self) -> str:
        """``cbc <version> (<origin>)``, read once from the executable's banner."""
        return _banner_version(self.path) + f" ({self.origin})"


def _package_dir(module: str) -> Path | None:
    spec = importlib.util.find_spec(module)
    if spec is None or not spec.submodule_search_locations:
        return None
    return Path(next(iter(spec.submodule_search_locations)))


def _executables(pattern: str) -> list[str]:
    return sorted(p for p in glob.glob(pattern) if os.path.isfile(p) and os.access(p, os.X_OK))


def find_cbc(choice: str = "auto") -> CbcBinary | None:
    """Locate a CBC executable without importing PuLP.

    Parameters
    ----------
    choice : {"auto", "cbcbox", "bundled"}
        ``auto`` takes cbcbox's CBC when installed, else PuLP's bundled one.

    Returns
    -------
    CbcBinary, or None when none was found.
    """
    if choice not in CBC_CHOICES:
        raise ValueError(f"cbc must be one of {', '.join(CBC_CHOICES)}, got {choice!r}")
    if choice in ("auto", "cbcbox") and (cbcbox := _package_dir("cbcbox")) is not None:
        import cbcbox  # tiny pure-Python package: picks the build (AVX2 or generic) for this CPU

        path = cbcbox.cbc_bin_path()
        if os.path.isfile(path):
            return CbcBinary(path, f"cbcbox {distribution_version('cbcbox')}")
        found = _executables(str(cbcbox / "cbc_dist*" / "bin" / "cbc*"))
        if found:
            return CbcBinary(found[0], f"cbcbox {distribution_version('cbcbox')}")
    if choice in ("auto", "bundled") and (pulp := _package_dir("pulp")) is not None:
        path = pulp / "solverdir" / "cbc" / _pulp_platform() / ("cbc.exe" if os.name == "nt" else "cbc")
        if path.is_file() and os.access(path, os.X_OK):
            return CbcBinary(str(path), "PuLP bundled")
    return None


def _pulp_platform() -> str:
    """PuLP's ``solverdir`` sub-folder for this machine (as ``pulp.apis.core`` names it)."""
    system = {"win32": "win", "cli": "win", "darwin": "osx"}.get(sys.platform, "linux")
    if sys.maxsize <= 2**32:
        return f"{system}/i32"
    return f"{system}/arm64" if platform.machine().lower() in ("aarch64", "arm64") else f"{system}/i64"


def cbc_availability(choice: str = "auto") -> Availability:
    """PuLP installed and a CBC executable found."""
    found = package_availability("pulp", hint="pip install pulp[cbc]")
    if not found:
        return found
    if find_cbc(choice) is None:
        return Availability.missing_binary("cbc", "pip install pulp[cbc] (cbcbox) or a PuLP wheel with CBC")
    return Availability.available(f"pulp {found.version}")


@functools.cache
def _banner_version(path: str) -> str:
    """CBC's version from its start-up banner (``Version: 2.10.3`` or ``CBC devel (git:...)``)."""
    try:
        banner = subprocess.run([path, "-quit"], capture_output=True, text=True, timeout=30).stdout
    except (OSError, subprocess.SubprocessError) as error:
        return f"cbc (version unknown: {error})"
    if match := re.search(r"Version:\s*(\S+)", banner):
        return f"cbc {match.group(1)}"
    if match := re.search(r"CBC\s+(\S+)\s+\((git:[0-9a-f]+)\)", banner):
        return f"cbc {match.group(1)} {match.group(2)}"
    return "cbc (version unknown)"


@dataclass(frozen=True)
class CbcOutcome:
    """How a CBC run ended, read from its log."""

    termination: Termination
    has_solution: bool
    bound: float | None
    message: str = ""


def read_cbc_log(log: str, time_limit: float | None = None) -> CbcOutcome:
    """Parse CBC's final ``Result - ...`` block (termination, incumbent, best possible objective).

    For a maximisation run with ``-max``, CBC prints the objective and the bound in the original sense.
    A packing problem is always feasible (choose nothing), so an "infeasible" verdict is CBC stopping
    inside preprocessing: CBC 2.10.3 reports "Pre-processing says infeasible or unbounded" when its
    time limit strikes there. With a time limit that is a TIME_LIMIT without incumbent, otherwise an
    error. CBC's development builds (cbcbox) print no result at all when the limit strikes right after
    the root LP: a log without a result whose total wall time reached ``time_limit`` (the run uses
    ``-timeMode elapsed``) is a TIME_LIMIT without incumbent too.
    """
    result = re.search(r"Result - (.*)", log)
    text = result.group(1) if result else ""
    objective = re.search(r"Objective value:\s*(\S+)", log)
    has_solution = objective is not None and "infeasible" not in text.lower()
    if "Optimal solution found" in text:
        return CbcOutcome(Termination.OPTIMAL, True, None)
    if "time" in text.lower():
        bound = _last_float(r"(?:Lower|Upper) bound:\s*(\S+)", log)
        if bound is None:
            bound = _last_float(r"best possible (\S+)\)", log)
        return CbcOutcome(Termination.TIME_LIMIT, has_solution, bound)
    if result is None and re.search(r"stopped on time limit", log, re.IGNORECASE):
        return CbcOutcome(Termination.TIME_LIMIT, False, None)  # stopped in the root LP: nothing proved
    claims_infeasible = "infeasible" in text.lower() or "says infeasible" in log
    if claims_infeasible and time_limit is not None:
        return CbcOutcome(Termination.TIME_LIMIT, False, None, "CBC stopped in preprocessing")
    elapsed = _last_float(r"Total time \(Wallclock seconds\):\s*(\S+)", log)
    if result is None and time_limit is not None and elapsed is not None and elapsed >= time_limit:
        return CbcOutcome(Termination.TIME_LIMIT, False, None, "CBC stopped after its root LP")
    return CbcOutcome(Termination.ERROR, False, None, "CBC log ends: " + " ".join(log.split()[-40:]))


def _last_float(pattern: str, text: str) -> float | None:
    found = re.findall(pattern, text)
    try:
        return float(found[-1]) if found else None
    except ValueError:
        return None


def run_cbc(
    lp, binary: CbcBinary, time_limit: float | None, seed: int, *, warm_start: bool = False
) -> tuple[CbcOutcome, float]:
    """Solve a ``pulp.LpProblem`` with ``COIN_CMD`` on ``binary``: gaps 0, cutoff increment
    `CBC_INCREMENT`, one thread, seeded; with ``warm_start``, the variables' initial values
    (``LpVariable.setInitialValue``) are CBC's start.

    Returns
    -------
    outcome : CbcOutcome
        Read from CBC's log: PuLP itself reports a solution stopped by the time limit as optimal.
    seconds : float
        Wall time of writing the MPS file, running CBC and reading its solution.
    """
    import pulp

    with tempfile.TemporaryDirectory(prefix="harness-cbc-") as folder:
        log_path = os.path.join(folder, "cbc.log")
        command = pulp.COIN_CMD(
            path=binary.path,
            msg=False,
            timeLimit=time_limit,
            gapRel=0,
            gapAbs=0,
            threads=1,
            options=[
                f"randomCbcSeed {seed % (2**31 - 1) + 1}",  # 0 would mean "seed from the clock"
                f"increment {CBC_INCREMENT:g}",
            ],
            logPath=log_path,
            warmStart=warm_start,
        )
        command.tmpDir = folder
        clock = Stopwatch()
        lp.solve(command)
        seconds = clock.lap()
        with open(log_path) as handle:
            outcome = read_cbc_log(handle.read(), time_limit)
    return outcome, seconds
