"""Solver backends for expression packing (Carrigan et al. 2020, sec. 4.5) behind one plugin interface.

Solvers are plugins registered in the ``harness.solvers`` entry-point group; `names` lists them without
importing any backend, `get` returns a ready instance, `info` reports availability and capabilities.
Beyond single expressions: artist refinement (sec. 4.5.3, `refine`, `RefiningSolver`) and the minimum
number of expressions with its ordered sequence (`minimum_expressions`, `ordered_minimum_sequence`).
The conformance checks for plugins live in `solvers.testing`. `Worker` runs functions in a persistent child
process that may crash or be killed without taking its caller along (a backend that cannot share a process
with the others, the harness's grid cells).

The plugin kit: a plugin's ``solve`` returns a `Result` (items, termination, bound); `load` (which `get`
applies) checks its arguments and turns its answer into a `packing.Solution` once for every plugin. An
exact plugin subclasses `ExactSolver` and solves the presolved `CliqueModel`; a heuristic fills an
`OpenExpression`, which keeps eq. 3b, the cap and the apart pairs; `package_availability` answers
``availability()`` without importing the backend. `write_mps` writes a `CliqueModel` as an MPS file and
`solu_line` its MIPLIB ``.solu`` line, for solvers outside the harness.

Names are imported from their modules on first use (PEP 562): listing the plugins imports neither a
backend nor the minimum-expression machinery.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import lazy_loader

if TYPE_CHECKING:
    from solvers._base import (
        Availability,
        AvailabilityStatus,
        Capabilities,
        Result,
        Setting,
        Solver,
        cpu_seconds,
        no_answer,
        package_availability,
    )
    from solvers._exact import ExactSolver
    from solvers._loaded import WARM_UP_LIMIT, LoadedSolver, load, warm_up
    from solvers._minimum import (
        MinimumExpressions,
        OrderedSequence,
        minimum_cover_solvers,
        minimum_expressions,
        ordered_minimum_sequence,
    )
    from solvers._model import CliqueModel
    from solvers._mps import MpsFile, column_names, solu_line, write_mps
    from solvers._open import OpenExpression
    from solvers._refine import Proposal, RefiningSolver, refine, rejecting
    from solvers._registry import (
        SolverUnavailableError,
        UnknownSolverError,
        availability,
        get,
        info,
        names,
        refresh,
        solver_class,
    )
    from solvers._worker import Worker, WorkerDied, WorkerError, wait_for_workers, worker

__getattr__, __dir__, __all__ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "_base": [
            "Availability",
            "AvailabilityStatus",
            "Capabilities",
            "Result",
            "Setting",
            "Solver",
            "cpu_seconds",
            "no_answer",
            "package_availability",
        ],
        "_exact": ["ExactSolver"],
        "_loaded": ["WARM_UP_LIMIT", "LoadedSolver", "load", "warm_up"],
        "_model": ["CliqueModel"],
        "_mps": ["MpsFile", "column_names", "solu_line", "write_mps"],
        "_open": ["OpenExpression"],
        "_minimum": [
            "MinimumExpressions",
            "OrderedSequence",
            "minimum_cover_solvers",
            "minimum_expressions",
            "ordered_minimum_sequence",
        ],
        "_refine": ["Proposal", "RefiningSolver", "refine", "rejecting"],
        "_registry": [
            "SolverUnavailableError",
            "UnknownSolverError",
            "availability",
            "get",
            "info",
            "names",
            "refresh",
            "solver_class",
        ],
        "_worker": ["Worker", "WorkerDied", "WorkerError", "wait_for_workers", "worker"],
    },
)
