"""The one place a plugin's answer becomes a `packing.Solution` (docs/architecture.md, "The plugin contract").

A plugin's ``solve`` returns a `Result`: its items, why it stopped and any bound. `load` wraps the plugin in
a `LoadedSolver`, whose ``solve`` checks the arguments before the plugin sees them, times the call, turns
an exception or a malformed answer into ``Termination.ERROR`` with a message naming the plugin (a
`KeyboardInterrupt` too, unless a stop signal raised it: `registry.raised_without_signal`), and
builds the `Solution`: items sorted, their shapes, the objective recomputed as the importance sum of
eq. 3a, the bound never below it, the backend name and version, the fallback that supplied the items, if
any. `solvers.get` returns loaded solvers, so every caller (the expression sequence, the harness, the
conformance checks) sees the same normalised answer whoever wrote the plugin.
"""

from __future__ import annotations

import functools
import inspect
import numbers
import os
import time
import traceback
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

from registry import raised_without_signal
from solvers import _strays as strays
from solvers._base import (
    Availability,
    Capabilities,
    Result,
    check_solve_arguments,
    cpu_seconds,
    make_solution,
    no_answer,
)

if TYPE_CHECKING:
    from packing import PackingProblem, Solution


class MalformedAnswer(ValueError):
    """A plugin returned something that is not a valid answer to the problem it was given."""


@dataclass(frozen=True)
class LoadedSolver:
    """A solver plugin behind the framework's argument checks, timing and normalisation.

    Attributes
    ----------
    plugin : Solver
        The plugin instance; its ``solve`` returns a `Result` (the plugin contract, `solvers.testing`).
        A solver of the framework that wraps a loaded one (refinement, a deadline, a worker process)
        answers the `packing.Solution` it was given, which is taken as it is named.
    """

    plugin: Any

    @property
    def name(self) -> str:
        """The plugin's registered name."""
        return self.plugin.name

    @property
    def capabilities(self) -> Capabilities:
        """The plugin's declared capabilities (per instance where the plugin sets them so)."""
        return self.plugin.capabilities

    def availability(self) -> Availability:
        """The plugin's availability."""
        return self.plugin.availability()

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Solution:
        """Solve one expression's problem (eq. 3) with the plugin and return the normalised `Solution`.

        Parameters
        ----------
        problem : PackingProblem
        time_limit : float, optional
            Seconds the plugin may search; None for no limit.
        seed : int in [0, 2**31 - 1]

        Returns
        -------
        Solution
            ``termination`` is ERROR, with the reason in ``message``, when the plugin raised or answered
            with items the problem does not have.

        Raises
        ------
        TypeError, ValueError
            For a ``problem`` that is not a `PackingProblem`, a non-positive or non-finite
            ``time_limit`` or a seed out of range (before the plugin is called).
        """
        check_solve_arguments(problem, time_limit, seed)
        before, pid = strays.children(), os.getpid()
        start, cpu = time.perf_counter(), cpu_seconds()
        try:
            try:
                answer = self.plugin.solve(problem, time_limit=time_limit, seed=seed)
            finally:
                if os.getpid() != pid:  # a copy of this process the plugin forked never answers
                    os._exit(0)
            elapsed, spent = time.perf_counter() - start, cpu_seconds() - cpu
            left = strays.children() - before
            if left:
                strays.stop(left)
                pids = ", ".join(map(str, sorted(left)))
                raise RuntimeError(
                    f"it left {len(left)} process(es) of its own behind (pid {pids}: a solver must wait for "
                    "what it starts, and answer from one process); they were stopped"
                )
            solution = _solution(problem, answer, elapsed, spent, self.name, self.plugin)
            return _with_overrun(solution, time_limit, elapsed, self.plugin)
        except Exception as error:  # a failing plugin is reported, never raised into the run
            detail = "".join(traceback.format_exception_only(error)).strip()
            return _failed(self, f"{self.name}: {detail}", time.perf_counter() - start)
        except KeyboardInterrupt:
            if not raised_without_signal():
                raise  # the user's Ctrl-C (or SIGTERM)
            detail = "raised KeyboardInterrupt itself (no Ctrl-C was given)"
            return _failed(self, f"{self.name}: {detail}", time.perf_counter() - start)


def load(solver: Any) -> LoadedSolver:
    """A solver plugin (class, instance or already loaded) behind the framework's normalisation.

    Parameters
    ----------
    solver : Solver class or instance, or LoadedSolver
        A class is instantiated without arguments.

    Examples
    --------
    >>> import numpy as np
    >>> from packing import problem_from_incidence
    >>> from solvers.greedy import GreedySolver
    >>> problem = problem_from_incidence(np.array([[1, 1, 0], [0, 1, 1], [0, 0, 1]]), [0.5, 0.9, 0.4])
    >>> load(GreedySolver).solve(problem).shapes  # the heaviest shape first: it blocks both others
    ('s1',)
    """
    if isinstance(solver, LoadedSolver):
        return solver
    return LoadedSolver(solver() if isinstance(solver, type) else solver)


#: Time limit of the warm-up solve when the caller gives none or a longer one (the tiny problem is solved in
#: milliseconds; an anytime heuristic searches until its limit).
WARM_UP_LIMIT = 5.0


def warm_up(solver: Any, time_limit: float | None = None) -> None:
    """Solve the problem of the generated ``tiny`` rig once, so that the imports and first-call costs of the
    solver's backend (and of the packing problem) are paid before any solve that counts: a benchmark's timed
    ones, the first expression of ``harness pack``.

    The solve gets ``time_limit`` when it is below `WARM_UP_LIMIT` (a solver that searches until its limit
    then warms up within the limit of the solves that follow). Whatever it answers or raises is ignored:
    a solver that fails here fails again on the solves that count, which report it.
    """
    import warnings

    import packing
    import rigs

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", packing.MissingTargetWarning)
            problem = packing.build_problem(rigs.generate("tiny"))
        limit = WARM_UP_LIMIT if time_limit is None else min(WARM_UP_LIMIT, time_limit)
        solver.solve(problem, time_limit=limit, seed=0)
    except (Exception, SystemExit):  # noqa: BLE001, S110 - the solves that count report the failure
        pass


def _solution(
    problem: PackingProblem, answer: Any, elapsed: float, spent: float, name: str, plugin: Any
) -> Solution:
    """The `Solution` of a plugin's `Result` (or of a wrapping solver's `Solution`, whose CPU time, measured
    where it solved, is kept); the plugin's reported version only when the answer names none."""
    from packing import Solution, Termination

    if not isinstance(answer, Result | Solution):
        raise MalformedAnswer(f"solve returned {type(answer).__name__}, not a solvers.Result")
    termination = answer.termination
    if not isinstance(termination, Termination):
        raise MalformedAnswer(f"termination {termination!r} is not a packing.Termination")
    items = _items(problem, answer.items)
    build_time = float(answer.build_time or 0.0)
    solve_time = max(elapsed - build_time, 0.0) if answer.solve_time is None else float(answer.solve_time)
    return make_solution(
        problem,
        items,
        termination=termination,
        bound=None if answer.bound is None else float(answer.bound),
        build_time=build_time,
        solve_time=solve_time,
        backend=answer.backend if isinstance(answer, Solution) and answer.backend else name,
        version=answer.version or _version(plugin),
        message=answer.message,
        fallback=answer.fallback,
        cpu_time=answer.cpu_time if isinstance(answer, Solution) and answer.cpu_time is not None else spent,
    )


#: A search that honours its time limit (``capabilities.time_limit``) may overshoot it by this share and
#: these seconds (a backend checks its clock between steps; CBC's files are written and read in its time).
OVERRUN_SHARE, OVERRUN_SECONDS = 0.25, 0.5


def _with_overrun(solution: Solution, time_limit: float | None, elapsed: float, plugin: Any) -> Solution:
    """``solution`` with its ``message`` saying so when a plugin that declares it honours time limits
    searched well past one (its search time, the whole call less its build time, beyond `OVERRUN_SHARE`
    and `OVERRUN_SECONDS` over the limit): the answer stands, its time is not comparable with others'."""
    capabilities = getattr(plugin, "capabilities", None)
    if time_limit is None or not getattr(capabilities, "time_limit", False):
        return solution
    searched = max(elapsed - solution.build_time, solution.solve_time)
    if searched <= time_limit * (1.0 + OVERRUN_SHARE) + OVERRUN_SECONDS:
        return solution
    note = f"overran its time limit: searched {searched:.3g} s, limit {time_limit:.3g} s"
    return replace(solution, message=f"{solution.message}; {note}" if solution.message else note)


def _items(problem: PackingProblem, items: Any) -> tuple[int, ...]:
    """The answer's items as Python ints, each an item of ``problem`` and none twice."""
    chosen = list(items)
    if not all(isinstance(i, numbers.Integral) and not isinstance(i, bool) for i in chosen):
        raise MalformedAnswer(f"items must be integers, got {chosen!r}")
    chosen = [int(i) for i in chosen]
    outside = [i for i in chosen if not 0 <= i < problem.n_items]
    if outside:
        raise MalformedAnswer(f"items {outside} are not items of a problem with {problem.n_items}")
    if len(set(chosen)) != len(chosen):
        raise MalformedAnswer(f"an item is chosen twice: {sorted(chosen)}")
    return tuple(chosen)


def _failed(solver: LoadedSolver, message: str, elapsed: float) -> Solution:
    from packing import Termination

    return no_answer(solver.name, Termination.ERROR, message, elapsed, version=_version(solver.plugin))


def _version(plugin: Any) -> str:
    """The backend version the plugin reports through its availability: read once per class when
    ``availability`` is a classmethod (the contract), else asked of the instance (a wrapping solver)."""
    if isinstance(inspect.getattr_static(type(plugin), "availability", None), classmethod):
        return _class_version(type(plugin))
    return _reported(plugin.availability)


@functools.cache
def _class_version(cls: type) -> str:
    return _reported(cls.availability)


def _reported(availability: Any) -> str:
    try:
        return availability().version or "unknown"
    except Exception:  # noqa: BLE001 - a plugin whose availability fails still gets a version string
        return "unknown"
