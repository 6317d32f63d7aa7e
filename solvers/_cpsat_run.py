"""Solving with CP-SAT the one way every CP-SAT model of the project is solved: integer weights scaled to
keep their order (`integer_weights`), deterministic exact parameters (`set_parameters`) and a search that a
Ctrl-C stops cleanly (`interruptible`).

The ``cpsat`` plugin (`solvers.cpsat`), the colouring model of the fewest expressions
(`solvers._colouring`) and the ordered minimum sequence (`solvers._minimum`) all solve through it.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import TypeVar

import numpy as np

from registry import stop_signals_deferred

#: Total of the scaled integer weights. CP-SAT needs integer coefficients; scaling the weights so that
#: they sum to 2**50 keeps every weight to about 1e-15 relative (far finer than the tie-break
#: perturbation of `packing`), while the objective stays far below CP-SAT's int64 range.
OBJECTIVE_SCALE_TOTAL = 2.0**50

_Answer = TypeVar("_Answer")


def integer_weights(weights: np.ndarray) -> tuple[np.ndarray, float]:
    """Weights scaled and rounded to int64, and the scale (integer = round(weight * scale)).

    Rounding moves each weight by at most ``0.5 / scale``, so an objective moves by at most
    ``I / (2 * scale)``: about ``I * 4e-16`` of the total weight. Two packings whose true objectives
    differ by more than that keep their order.
    """
    total = float(np.abs(weights).sum())
    scale = OBJECTIVE_SCALE_TOTAL / total if total > 0 else 1.0
    return np.rint(weights * scale).astype(np.int64), scale


def solve_cp_model(model, time_limit: float | None, seed: int, workers: int = 1):
    """Solve a ``cp_model.CpModel`` with the deterministic exact settings (`set_parameters`), Ctrl-C
    stopping it (`interruptible`).

    Returns
    -------
    (CpSolver, CpSolverStatus)
        The solver, to read the solution from, and the status.
    """
    from ortools.sat.python import cp_model

    solver = cp_model.CpSolver()
    set_parameters(solver.parameters, time_limit, seed, workers)
    status = interruptible(lambda: solver.solve(model), solver.stop_search)
    return solver, status


def set_parameters(parameters, time_limit: float | None, seed: int, workers: int) -> None:
    """Deterministic exact CP-SAT settings: gaps 0, fixed seed and worker count, native time limit.

    CP-SAT's own Ctrl-C handler stays off (``catch_sigint_signal``): it would turn the user's Ctrl-C into
    an early, seemingly normal end of the search, and when the solver is destroyed it resets SIGINT to the
    operating system's default, after which a Ctrl-C kills the process without any clean-up. The solve
    runs in a thread instead (`interruptible`), so that Python's own handler sees the Ctrl-C at once.
    """
    parameters.num_workers = workers
    parameters.random_seed = int(seed)
    parameters.relative_gap_limit = 0.0
    parameters.absolute_gap_limit = 0.0
    parameters.log_search_progress = False
    parameters.catch_sigint_signal = False
    if time_limit is not None:
        parameters.max_time_in_seconds = float(time_limit)


def interruptible(solve: Callable[[], _Answer], stop: Callable[[], None]) -> _Answer:
    """``solve()`` run in a thread while this one waits, so that a Ctrl-C (or SIGTERM) reaches Python's
    handler during a long solve: the search is then stopped (``stop()``), awaited, and the
    `KeyboardInterrupt` raised here. CP-SAT releases the GIL while it searches.

    Returns
    -------
    What ``solve()`` returned; an exception it raised is raised here.
    """
    outcome: dict[str, object] = {}
    finished = threading.Event()

    def run() -> None:
        try:
            outcome["answer"] = solve()
        except BaseException as error:  # noqa: BLE001 - raised again in the waiting thread
            outcome["error"] = error
        finally:
            finished.set()

    started = False
    try:
        with stop_signals_deferred():  # (so that a thread that started is always awaited)
            threading.Thread(target=run, name="cp-sat solve", daemon=True).start()
            started = True
        finished.wait()
    except KeyboardInterrupt:
        if started:
            stop()
            with stop_signals_deferred():  # a stopped search ends within milliseconds
                finished.wait()
        raise
    if "error" in outcome:
        raise outcome["error"]
    return outcome["answer"]
