"""Reading CBC's log: PuLP reports a time-limited incumbent as optimal, so termination comes from here."""

from packing import Termination
from solvers._cbc import find_cbc, read_cbc_log


def test_time_limit_block_gives_incumbent_and_bound():
    log = "Result - Stopped on time limit\nObjective value:  20.06\nUpper bound:  24.5054\nGap: -0.18\n"
    outcome = read_cbc_log(log, time_limit=0.02)
    assert (outcome.termination, outcome.has_solution, outcome.bound) == (
        Termination.TIME_LIMIT,
        True,
        24.5054,
    )


def test_optimal_block():
    outcome = read_cbc_log("Result - Optimal solution found\n\nObjective value:  14.2\n")
    assert (outcome.termination, outcome.has_solution) == (Termination.OPTIMAL, True)


def test_spurious_preprocessing_infeasibility_under_a_time_limit():
    log = (
        "Continuous objective value is 24.0281 - 0.01 seconds\nPre-processing says infeasible or unbounded\n"
    )
    assert read_cbc_log(log, time_limit=0.02).termination is Termination.TIME_LIMIT
    outcome = read_cbc_log(log, time_limit=None)
    assert outcome.termination is Termination.ERROR and "Pre-processing says infeasible" in outcome.message


def test_both_cbc_executables_are_found_and_versioned():
    bundled = find_cbc("bundled")
    assert bundled is not None and bundled.version.startswith("cbc 2.10.3")
    assert find_cbc("auto") is not None


DEVEL_ROOT_LP_ONLY = """CBC devel (git:146ce89) - COIN-OR Branch and Cut
  args: pulp.mps -max -mips pulp.mst -sec 0.02 -timeMode elapsed -solve
LP Optimal - Frac: 121/136 (89.0%)   Obj: 23.8748   Iters: 341   Time: 0.019s
Total time (Wallclock seconds): 0.0277498   (CPU seconds):             0.017888
"""


def test_a_development_build_stopped_after_its_root_lp_is_a_time_limit_without_incumbent():
    """cbcbox's CBC reports no result when its limit strikes right after the root LP (seen on a busy
    machine with a 0.02 s limit): that is a stop at the limit, not a failure, but only once the limit
    was reached."""
    outcome = read_cbc_log(DEVEL_ROOT_LP_ONLY, time_limit=0.02)
    assert (outcome.termination, outcome.has_solution, outcome.bound) == (Termination.TIME_LIMIT, False, None)
    assert read_cbc_log(DEVEL_ROOT_LP_ONLY, time_limit=0.05).termination is Termination.ERROR
    assert read_cbc_log(DEVEL_ROOT_LP_ONLY, time_limit=None).termination is Termination.ERROR
