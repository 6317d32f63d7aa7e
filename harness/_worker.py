"""A local worker process: ``python -m harness._worker FD PARENT`` serves cells over the connected socket FD.

The parent (`harness._executors.LocalExecutor`, process id PARENT) sends cell specs as dicts; for each the
worker warms the cell's solver up once (untimed, see `harness._cell.warm_up`), replies ``("started", id)``,
runs the cell and replies ``("done", id, outcome)`` (record rows, or `harness._cell.Lost`). ``None`` or a
closed socket ends the worker, and so does the end of its parent, even by ``kill -9``
(`solvers._worker.exit_with_parent`): a worker never outlives the run that started it. Ctrl-C is left to
the parent, which stops its workers itself.
"""

from __future__ import annotations

import multiprocessing.connection
import signal
import sys

from harness._cell import run_cell, warm_up
from harness._grid import CellSpec
from solvers._worker import exit_with_parent


def serve(connection: multiprocessing.connection.Connection) -> None:
    """Answer cells until the parent sends None or goes away."""
    while True:
        try:
            message = connection.recv()
        except (EOFError, OSError):
            return
        if message is None:
            return
        spec = CellSpec.from_dict(message)
        warm_up(spec.solver)
        try:
            connection.send(("started", spec.id))
            connection.send(("done", spec.id, run_cell(spec)))
        except OSError:  # the parent is gone
            return


def main() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    exit_with_parent(int(sys.argv[2]))
    serve(multiprocessing.connection.Connection(int(sys.argv[1])))


if __name__ == "__main__":
    main()
