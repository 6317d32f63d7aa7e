"""The timing gate's power and its false alarms, measured on this machine with another CPU-bound job running.

A scratch clone of this repository gets three more commits: one that changes nothing a solve runs (its
README), and two that make CP-SAT's every solve 1.25x and 2x slower (a wrapper plugin adding CPU work in
proportion to the solve's own). ``harness compare --commits`` over the ``ci`` suite (tiny and arkit52 with
every solver, the first expressions of the 1,000-shape film rig, whose solves take 10-100 ms, with the exact
solvers; ebfr's transfer) then runs 20 times on the unchanged commit and 10 times on each slowed one:

- **A/A**: no case judged slower or faster in any of the 20;
- **power**: CP-SAT judged slower in at least 9 of 10 comparisons at 1.25x, in 10 of 10 at 2x;
- **no side effects**: in those, no other solver gets a verdict;
- **budget**: each comparison within 5 minutes.

About 100 minutes in all: ``python -m pytest -m slow --benchmark-enable tests/benchmarks/test_bench_gate.py``.
"""

from __future__ import annotations

import subprocess
import sys

import pytest
from rich.console import Console

import harness
from reports._commits_compare import run
from tests.scratch_repository import clone, commit_all, git, replace_entry_point

SLOWED = '''"""CP-SAT spending a share of its own CPU time again, for the timing gate's benchmark."""

import time

from solvers.cpsat import CpSatSolver

SHARE = {share}


class SlowedCpSat(CpSatSolver):
    def solve(self, problem, *, time_limit=None, seed=0):
        start = time.process_time()
        result = super().solve(problem, time_limit=time_limit, seed=seed)
        end = time.process_time() + SHARE * (time.process_time() - start)
        while time.process_time() < end:
            pass
        return result
'''


@pytest.fixture(scope="module")
def scratch(tmp_path_factory: pytest.TempPathFactory) -> dict[str, object]:
    """The clone and its commits: ``base``, ``unchanged``, ``1.25x`` and ``2x`` (each on ``base``)."""
    folder = clone(tmp_path_factory.mktemp("gate") / "repo")
    commits = {"base": git(folder, "rev-parse", "HEAD")}
    (folder / "README.md").write_text((folder / "README.md").read_text() + "\nA line that no solve reads.\n")
    commits["unchanged"] = commit_all(folder, "README only")
    for name, share in (("1.25x", 0.25), ("2x", 1.0)):
        git(folder, "checkout", "-q", commits["base"])
        (folder / "solvers" / "_slowed.py").write_text(SLOWED.format(share=share))
        replace_entry_point(
            folder, 'cpsat = "solvers.cpsat:CpSatSolver"', 'cpsat = "solvers._slowed:SlowedCpSat"'
        )
        commits[name] = commit_all(folder, f"cpsat {name} slower")
    return {"folder": folder, **commits}


@pytest.fixture(scope="module")
def other_job():
    """Another CPU-bound job on the machine for as long as the comparisons run."""
    hog = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    yield
    hog.kill()
    hog.wait()


def _compare(scratch: dict[str, object], head: str):
    found = run(
        scratch["folder"], scratch["base"], scratch[head], harness.suite("ci"), rounds=3, repeat=3,
        sample_time=0.01, budget=300.0, alpha=0.01, threshold=0.1, fail_above=1.5, warn_above=1.25,
        console=Console(quiet=True),
    )  # fmt: skip
    verdicts = {case.case: case.test.verdict for case in found.comparison.cases}
    return found, verdicts


@pytest.mark.slow
@pytest.mark.parametrize(("head", "times"), [("unchanged", 20), ("1.25x", 10), ("2x", 10)])
def test_the_gate_sees_a_slow_down_and_nothing_else(benchmark, scratch, other_job, head, times):
    if benchmark.disabled:
        pytest.skip("a timing verdict's power is measured in a benchmark run (--benchmark-enable)")
    flagged, side_effects, seconds, ratios = 0, [], [], []
    for _ in range(times):
        found, verdicts = _compare(scratch, head)
        seconds.append(found.comparison.measurement.seconds)
        cpsat = {case: verdict for case, verdict in verdicts.items() if case.endswith("/cpsat")}
        others = {case: verdict for case, verdict in verdicts.items() if case not in cpsat}
        side_effects += [
            f"{case}: {verdict}" for case, verdict in others.items() if verdict in ("slower", "faster")
        ]
        if head == "unchanged":
            side_effects += [
                f"{case}: {verdict}" for case, verdict in cpsat.items() if verdict in ("slower", "faster")
            ]
        flagged += any(verdict == "slower" for verdict in cpsat.values())
        ratios += [case.test.ratio for case in found.comparison.cases if case.case.endswith("/cpsat")]
        assert found.comparison.problems == [], found.comparison.problems
    benchmark.extra_info.update(
        {"comparisons": times, "flagged": flagged, "side_effects": side_effects, "seconds": seconds,
         "cpsat_ratios": ratios}
    )  # fmt: skip
    print(head, flagged, "of", times, "flagged; side effects:", side_effects, "; longest", max(seconds), "s")
    assert side_effects == []
    assert max(seconds) <= 300.0
    if head == "1.25x":
        assert flagged >= 9
    if head == "2x":
        assert flagged == times
