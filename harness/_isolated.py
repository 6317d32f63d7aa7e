"""A solver in a worker process of its own, for the commands that solve in the harness's process otherwise
(``harness pack``, ``harness instances export``; a run's cells run in workers already).

`IsolatedSolver` runs every solve in a worker process (`solvers.Worker`): a solver that crashes the
interpreter (``os.abort``, a segfault in a backend library) or calls ``sys.exit`` loses its process, not the
command, and its failure becomes a `packing.Solution` with ``Termination.ERROR`` like a raised exception or a
malformed answer (`solvers.LoadedSolver`); the command says why in one line (`SolverFailure`).

A solve given a time limit gets its answer within the limit and `late_allowance` of it: a solver that
overruns it (one that ignores its limit, or has none) is stopped with its process, and the solve answers
``Termination.TIME_LIMIT`` with no items, as a solve its limit stopped before a first incumbent does.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Final

from registry import HarnessError

if TYPE_CHECKING:
    from packing import PackingProblem, Solution
    from solvers import Availability, Capabilities, LoadedSolver

#: Solvers loaded in this worker process, by label.
_LOADED: dict[str, LoadedSolver] = {}

#: Seconds a solve may overrun its time limit, at least (model building, answer transfer) ...
LATE_SECONDS = 2.0
#: ... and as a share of the limit, when that is more.
LATE_SHARE = 0.1

#: What `IsolatedSolver._reply` returns when no reply came in time.
_NO_REPLY: Final = object()


def late_allowance(time_limit: float) -> float:
    """Seconds a solve with ``time_limit`` may overrun it before it is stopped."""
    return max(LATE_SECONDS, LATE_SHARE * time_limit)


class SolverFailure(HarnessError):
    """A solver failed on an expression (one line: solver, expression, reason)."""


def load_in_worker(label: str) -> tuple[str, Capabilities]:
    """Load the solver ``label`` in the worker process (its library import paid before the first solve);
    its name and capabilities."""
    from harness._plugins import load_solver

    if label not in _LOADED:
        _LOADED[label] = load_solver(label)
    return _LOADED[label].name, _LOADED[label].capabilities


def warm_in_worker(label: str) -> None:
    """Warm the solver ``label`` up in the worker process (`solvers.warm_up`), so that the imports of its
    backend and of the packing problem are paid while the caller analyses the rig."""
    from solvers import warm_up

    load_in_worker(label)
    warm_up(_LOADED[label])


def availability_in_worker(label: str) -> Availability:
    """The availability of the solver ``label``, asked in the worker process."""
    load_in_worker(label)
    return _LOADED[label].availability()


def solve_in_worker(label: str, problem: PackingProblem, time_limit: float | None, seed: int) -> Solution:
    """One solve in the worker process; a solver that calls ``sys.exit`` answers ``Termination.ERROR``."""
    load_in_worker(label)
    start = time.perf_counter()
    try:
        return _LOADED[label].solve(problem, time_limit=time_limit, seed=seed)
    except SystemExit as exit_:
        return failed(label, f"it called sys.exit({exit_.code!r})", time.perf_counter() - start)


def failed(backend: str, message: str, elapsed: float = 0.0) -> Solution:
    """The ``Termination.ERROR`` answer of ``backend`` (`solvers.no_answer`), the reason in ``message``."""
    from packing import Termination
    from solvers import no_answer

    return no_answer(backend, Termination.ERROR, message, elapsed)


def _solution(reply: object, backend: str) -> Solution:
    """The worker's reply to a solve, when it is a `packing.Solution`; else a failure saying what came."""
    from packing import Solution

    if isinstance(reply, Solution):
        return reply
    return failed(backend, f"its worker answered {type(reply).__name__}, not a solution")


def _stopped(backend: str, time_limit: float, elapsed: float) -> Solution:
    """The ``Termination.TIME_LIMIT`` answer of ``backend`` stopped for overrunning ``time_limit``."""
    from packing import Termination
    from solvers import no_answer

    message = f"no answer within its time limit of {time_limit:g}s; stopped after {elapsed:.1f}s"
    return no_answer(backend, Termination.TIME_LIMIT, message, elapsed)


class IsolatedSolver:
    """A solver plugin that solves in a worker process of its own (see the module docstring).

    Parameters
    ----------
    label : str
        The solver's label (``cpsat`` or ``cpsat[workers=2]``).

    Notes
    -----
    The worker (one per label and process, `solvers.worker`) starts at once, loads the plugin and warms it up
    (`solvers.warm_up`) while the caller goes on (loading and analysing the rig); the plugin's library is
    imported there only. Its name and capabilities, and the first solve, wait for it.
    """

    def __init__(self, label: str) -> None:
        import solvers

        self._label = label
        self._worker = solvers.worker(f"pack-{label}")
        self._worker.send("harness._isolated:load_in_worker", label)
        self._worker.send("harness._isolated:warm_in_worker", label)
        self._loaded: tuple[str, Capabilities] | None = None
        self._warming = True

    @property
    def name(self) -> str:
        """The plugin's registered name."""
        return self._plugin()[0]

    @property
    def capabilities(self) -> Capabilities:
        """The plugin's declared capabilities."""
        return self._plugin()[1]

    def availability(self) -> Availability:
        """The plugin's availability."""
        self._ready()
        return self._worker.call("harness._isolated:availability_in_worker", self._label)  # type: ignore[return-value]

    def _ready(self, end: float | None = None) -> bool:
        """Wait for the worker to have loaded and warmed up the plugin (see `_plugin` for its errors);
        False when the warm-up did not end by ``end`` (`time.monotonic`), which stopped the worker."""
        from solvers import WorkerError

        self._plugin()
        if self._warming:
            self._warming = False
            try:
                return self._reply(end) is not _NO_REPLY
            except WorkerError:  # it died warming up: the next call starts a fresh process and says how
                pass
        return True

    def _reply(self, end: float | None) -> object:
        """The reply to the oldest call sent, or `_NO_REPLY` when none came by ``end`` (`time.monotonic`;
        None: wait for it), and the worker, left working on the call, is stopped.

        Raises
        ------
        solvers.WorkerError
            The call raised, or the process died (`solvers.WorkerDied`).
        """
        from solvers import wait_for_workers

        if end is not None:
            wait_for_workers([self._worker], max(0.0, end - time.monotonic()))
            if not self._worker.ready():
                self._worker.stop()
                return _NO_REPLY
        return self._worker.receive()

    def _plugin(self) -> tuple[str, Capabilities]:
        """Name and capabilities of the plugin, once the worker has loaded it.

        Raises
        ------
        SolverFailure
            When it could not: the plugin raised, or the process died.
        """
        from solvers import WorkerDied, WorkerError

        if self._loaded is None:
            try:
                self._loaded = self._worker.receive()  # type: ignore[assignment]
            except WorkerDied as error:
                raise SolverFailure(
                    f"solver {self._label} could not be loaded: its process died ({error.exit})"
                ) from None
            except WorkerError as error:
                raise SolverFailure(
                    f"solver {self._label} could not be loaded: {last_line(str(error))}"
                ) from None
        assert self._loaded is not None
        return self._loaded

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Solution:
        """The plugin's answer from the worker; ``Termination.ERROR`` saying how the worker failed, or
        ``Termination.TIME_LIMIT`` with no items when ``time_limit`` and `late_allowance` passed without
        an answer (the worker is then stopped)."""
        from solvers import WorkerDied, WorkerError

        start = time.monotonic()
        end = None if time_limit is None else start + time_limit + late_allowance(time_limit)
        try:
            if self._ready(end):
                self._worker.send("harness._isolated:solve_in_worker", self._label, problem, time_limit, seed)
                reply = self._reply(end)
                if reply is not _NO_REPLY:
                    return _solution(reply, self.name)
            assert time_limit is not None  # (only a solve with a time limit goes unanswered)
            return _stopped(self.name, time_limit, time.monotonic() - start)
        except WorkerDied as error:
            reason = f"its process died ({error.exit})"
        except WorkerError as error:
            reason = last_line(str(error))
        return failed(self.name, reason, time.monotonic() - start)

    def close(self) -> None:
        """Leave the worker for the next packing of this process with the same solver (it ends with the
        process), or end it when a call is unanswered."""
        if self._worker.pending:
            self._worker.stop()

    def __enter__(self) -> IsolatedSolver:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


def last_line(text: str) -> str:
    """The last non-empty line of a message (a traceback's names the exception)."""
    lines = [line.strip() for line in str(text).splitlines() if line.strip()]
    return lines[-1] if lines else ""
