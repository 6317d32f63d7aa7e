"""Reading CBC's log: PuLP reports a time-limited incumbent as optimal, so termination comes from here."""

from packing import Termination
from solvers._cbc import find_cbc, read_cbc_log


def test_time_limit_block_gives_incumbent_and_bound():
    log = "Result - Stopped on time limit\nObjective value:  20.06\nUpper bound:  24.5054\nGap: -0.18\n"
    outcome = read_cbc_log(log, time_limited=True)
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
    assert read_cbc_log(log, time_limited=True).termination is Termination.TIME_LIMIT
    outcome = read_cbc_log(log, time_limited=False)
    assert outcome.termination is Termination.ERROR and "Pre-processing says infeasible" in outcome.message


def test_both_cbc_executables_are_found_and_versioned():
    bundled = find_cbc("bundled")
    assert bundled is not None and bundled.version.startswith("cbc 2.10.3")
    assert find_cbc("auto") is not None
