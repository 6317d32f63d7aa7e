"""The solver plugin contract: capabilities, availability, the `Solver` protocol (docs/architecture.md).

A solver plugin is a class with a ``name``, typed ``capabilities``, a cheap ``availability()`` that never
imports the backend library, and ``solve(problem, *, time_limit, seed) -> Result``: the items it chose, why
it stopped and any bound it proved. Everything else a `packing.Solution` holds (sorted items, shape names,
the objective of eq. 3a, timings, backend and version) is filled in once by the framework
(`solvers.load`, which `solvers.get` applies), so built-in and third-party plugins are treated alike.
"""

from __future__ import annotations

import functools
import importlib.metadata
import importlib.util
import math
import resource
import time
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any, ClassVar, Protocol, runtime_checkable

import numpy as np

from registry import (
    Availability as Availability,
    AvailabilityStatus as AvailabilityStatus,
    Setting as Setting,
    package_availability as package_availability,
)

if TYPE_CHECKING:  # imported where used, so that listing plugins does not import the method
    from packing import PackingProblem, Solution, Termination

#: Relative shortfall of a reported bound below its objective that is taken for rounding (backends' own
#: feasibility tolerances), not for a false claim.
BOUND_SLACK = 1e-6
#: Largest seed every backend accepts (CP-SAT and HiGHS take a 32-bit signed int).
MAX_SEED = 2**31 - 1


@dataclass(frozen=True)
class Capabilities:
    """What a solver plugin can do (typed tags, as scikit-learn's estimator tags).

    Attributes
    ----------
    exact : bool
        Proves optimality of eq. 3 (MILP / CP-SAT); False for heuristics (Algorithm 2 and variants).
    time_limit : bool
        Honours ``time_limit`` natively and returns its incumbent with ``Termination.TIME_LIMIT``.
    supports_cap : bool
        Respects the per-expression cap on blendshapes (sec. 6).
    deterministic : bool
        The same problem and seed give the same items.
    isolated_process : bool
        Runs its backend in a separate worker process (its library cannot share a process with others).
    max_overlap : float in [0, 1)
        Declared share of an item's active vertices that may already be active in the expression when the
        item is added (Algorithm 2 with allowed overlap, sec. 4.5.2). 0 for every solver of eq. 3, whose
        chosen items never share an active vertex (eq. 3b). Results are verified with this allowance and
        no other.
    minimum_cover : bool
        Also proves the fewest expressions that cover every item (`solvers.minimum_expressions`): the
        plugin implements ``solve_colouring(problem, start, lower, *, time_limit, seed)``.
    warm_start : bool
        An `ExactSolver` whose ``solve_model`` takes a start packing, ``start=`` (indices of the model's
        items, possibly empty), and hands it to its backend as an incumbent or hint. The framework passes
        ``start`` only to plugins that declare it, so a plugin written before it existed keeps working.
    """

    exact: bool
    time_limit: bool
    supports_cap: bool = True
    deterministic: bool = True
    isolated_process: bool = False
    max_overlap: float = 0.0
    minimum_cover: bool = False
    warm_start: bool = False

    def __post_init__(self) -> None:
        if not 0.0 <= self.max_overlap < 1.0:
            raise ValueError(
                f"Capabilities.max_overlap must be a fraction in [0, 1), got {self.max_overlap!r}"
            )

    @property
    def strict(self) -> bool:
        """Chosen items never share an active vertex (eq. 3b): ``max_overlap == 0``."""
        return self.max_overlap == 0.0

    def as_dict(self) -> dict[str, bool | float]:
        """Plain mapping for JSON output."""
        return {**asdict(self), "strict": self.strict}


@dataclass(frozen=True)
class Result:
    """What a solver plugin returns for one packing problem: its answer and nothing derived from it.

    Attributes
    ----------
    items : sequence of int
        Chosen items of the problem, in any order (empty when none was found).
    termination : Termination
        Why the plugin stopped: COMPLETED for a heuristic that ran to its end, OPTIMAL when optimality of
        eq. 3 is proved, TIME_LIMIT with the incumbent, INFEASIBLE, or ERROR with a ``message``.
    bound : float or None
        Proved upper bound on eq. 3a, if any.
    build_time, solve_time : float or None
        Seconds to build the backend's model and to solve it, where the plugin measures them itself (an
        isolated worker does); None lets the framework time the whole call as solve time.
    version : str
        The backend version that ran, when it differs from what ``availability()`` reports.
    message : str
        Details for the records (an error text, the options used).
    fallback : str
        The method that supplied ``items`` when they are not the backend's own (``"greedy"``: Algorithm 2's
        packing answered for a backend stopped by its time limit with none or a worse one); empty otherwise.
    """

    items: Sequence[int]
    termination: Termination
    bound: float | None = None
    build_time: float | None = None
    solve_time: float | None = None
    version: str = ""
    message: str = ""
    fallback: str = ""


@runtime_checkable
class Solver(Protocol):
    """A backend that solves one expression's packing problem (eq. 3).

    Implementations keep the backend import inside their methods, so that listing solvers stays cheap
    and a missing backend never breaks the others.
    """

    name: ClassVar[str]
    capabilities: ClassVar[Capabilities]
    #: Optional: the keyword arguments the class takes, with their types and ranges (`Setting`), checked
    #: before the solver is made (``cpsat[workers=2]``) and shown by ``harness list``.
    settings: ClassVar[tuple[Setting, ...]]

    @classmethod
    def availability(cls) -> Availability:
        """Whether the backend can run here (cheap: never imports it)."""
        ...

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Result:
        """Choose items for one expression (eq. 3). Arguments arrive checked; see `Result`."""
        ...


@functools.cache
def distribution_version(distribution: str) -> str:
    """Installed version of a distribution, or an empty string (read once per process)."""
    try:
        return importlib.metadata.version(distribution)
    except importlib.metadata.PackageNotFoundError:
        return ""


def check_solve_arguments(problem: Any, time_limit: float | None, seed: int) -> None:
    """Raise one clear ValueError/TypeError for bad `Solver.solve` arguments."""
    from packing import PackingProblem

    if not isinstance(problem, PackingProblem):
        raise TypeError(f"problem must be a packing.PackingProblem, got {type(problem).__name__}")
    if time_limit is not None and not (isinstance(time_limit, int | float) and math.isfinite(time_limit)):
        raise ValueError(f"time_limit must be a finite number of seconds or None, got {time_limit!r}")
    if time_limit is not None and time_limit <= 0:
        raise ValueError(f"time_limit must be positive, got {time_limit!r}")
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or not 0 <= seed <= MAX_SEED:
        raise ValueError(f"seed must be an integer in [0, {MAX_SEED}], got {seed!r}")


def make_solution(
    problem: PackingProblem,
    items: Iterable[int],
    *,
    termination: Termination,
    bound: float | None,
    build_time: float,
    solve_time: float,
    backend: str,
    version: str,
    message: str = "",
    fallback: str = "",
    cpu_time: float | None = None,
) -> Solution:
    """A `Solution` with items sorted, shape names and the objective recomputed from the problem's weights.

    Backends report the chosen items only; the objective is always evaluated here in double precision so
    that every backend's value is comparable to 1e-9. It is the importance sum of eq. 3a: the tie-break
    perturbation that backends maximise along with it stays inside them. A bound proved on the perturbed
    objective also bounds the importance sum: one within `BOUND_SLACK` (relative) of the objective is
    reported as at least the objective (the objective itself when optimal), one further below is kept as
    claimed, so that the checker rejects an answer its own bound contradicts.
    """
    from packing import Solution, Termination

    chosen = tuple(sorted(int(i) for i in items))
    objective = problem.unperturbed_objective(chosen)
    if bound is not None and bound >= objective - BOUND_SLACK * max(1.0, abs(objective)):
        bound = objective if termination is Termination.OPTIMAL else max(float(bound), objective)
    elif bound is None and termination is Termination.OPTIMAL:
        bound = objective
    return Solution(
        items=chosen,
        shapes=problem.shapes_of(chosen),
        objective=objective,
        bound=bound,
        termination=termination,
        build_time=float(build_time),
        solve_time=float(solve_time),
        cpu_time=None if cpu_time is None else float(cpu_time),
        backend=backend,
        version=version,
        message=message,
        fallback=fallback,
    )


def no_answer(
    backend: str, termination: Termination, message: str, elapsed: float = 0.0, *, version: str = ""
) -> Solution:
    """An answer of ``backend`` without items: why (``termination``, ``message``) and after how long.

    What a failed solve gives instead of raising (a plugin that raised or answered nonsense, a worker process
    that died or overran its time limit, a deadline already spent), so that the expression sequence stops at
    an empty expression and its caller says why.
    """
    from packing import Solution

    return Solution(
        items=(),
        shapes=(),
        objective=0.0,
        bound=None,
        termination=termination,
        build_time=0.0,
        solve_time=float(elapsed),
        backend=backend,
        version=version,
        message=message,
    )


def trivial_bound(problem: PackingProblem, items: np.ndarray | None = None) -> float:
    """Upper bound on eq. 3a that needs no solver: the sum of the positive weights (of ``items`` only, for
    the packings of those items)."""
    weights = np.asarray(problem.weights) if items is None else np.asarray(problem.weights)[items]
    return float(np.clip(weights, 0.0, None).sum())


def cpu_seconds() -> float:
    """CPU seconds this process has used so far: every thread, the child processes it waited for (a
    backend run as a program), and the calls it made to worker processes (`solvers._worker`).

    A solve's CPU time is the difference of two readings; unlike its wall time, it does not count the
    moments the scheduler gave to another job.
    """
    from solvers._worker import worker_cpu_seconds

    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime + worker_cpu_seconds()


class Stopwatch:
    """Seconds elapsed since creation or the last `lap` (``time.perf_counter``)."""

    def __init__(self) -> None:
        self._start = time.perf_counter()

    def lap(self) -> float:
        """Seconds since the previous lap, and start a new one."""
        now = time.perf_counter()
        elapsed, self._start = now - self._start, now
        return elapsed
