"""Solver backends for expression packing (Carrigan et al. 2020, sec. 4.5) behind one plugin interface.

Solvers are plugins registered in the ``harness.solvers`` entry-point group; `names` lists them without
importing any backend, `get` returns a ready instance, `info` reports availability and capabilities.
Beyond single expressions: artist refinement (sec. 4.5.3, `refine`, `RefiningSolver`) and the minimum
number of expressions with its ordered sequence (`minimum_expressions`, `ordered_minimum_sequence`).
The conformance checks for plugins live in `solvers.testing`.

The plugin kit: a plugin's ``solve`` returns a `Result` (items, termination, bound); `load` (which `get`
applies) checks its arguments and turns its answer into a `packing.Solution` once for every plugin. An
exact plugin subclasses `ExactSolver` and solves the presolved `CliqueModel`; a heuristic fills an
`OpenExpression`, which keeps eq. 3b, the cap and the apart pairs; `package_availability` answers
``availability()`` without importing the backend.

Names are imported from their modules on first use (PEP 562): listing the plugins imports neither a
backend nor the minimum-expression machinery.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from solvers._base import (
        Availability,
        AvailabilityStatus,
        Capabilities,
        Result,
        Solver,
        package_availability,
    )
    from solvers._exact import ExactSolver
    from solvers._loaded import LoadedSolver, load
    from solvers._minimum import (
        MinimumExpressions,
        OrderedSequence,
        minimum_cover_solvers,
        minimum_expressions,
        ordered_minimum_sequence,
    )
    from solvers._model import CliqueModel
    from solvers._open import OpenExpression
    from solvers._refine import Proposal, RefiningSolver, refine, rejecting
    from solvers._registry import (
        SolverInfo,
        SolverUnavailableError,
        UnknownSolverError,
        availability,
        get,
        info,
        names,
        refresh,
        solver_class,
    )

#: The module that defines each public name.
_MODULE_OF = {
    "Availability": "solvers._base",
    "AvailabilityStatus": "solvers._base",
    "Capabilities": "solvers._base",
    "Result": "solvers._base",
    "Solver": "solvers._base",
    "package_availability": "solvers._base",
    "ExactSolver": "solvers._exact",
    "LoadedSolver": "solvers._loaded",
    "load": "solvers._loaded",
    "CliqueModel": "solvers._model",
    "OpenExpression": "solvers._open",
    "MinimumExpressions": "solvers._minimum",
    "OrderedSequence": "solvers._minimum",
    "minimum_cover_solvers": "solvers._minimum",
    "minimum_expressions": "solvers._minimum",
    "ordered_minimum_sequence": "solvers._minimum",
    "Proposal": "solvers._refine",
    "RefiningSolver": "solvers._refine",
    "refine": "solvers._refine",
    "rejecting": "solvers._refine",
    "SolverInfo": "solvers._registry",
    "SolverUnavailableError": "solvers._registry",
    "UnknownSolverError": "solvers._registry",
    "availability": "solvers._registry",
    "get": "solvers._registry",
    "info": "solvers._registry",
    "names": "solvers._registry",
    "refresh": "solvers._registry",
    "solver_class": "solvers._registry",
}

__all__ = [
    "Availability",
    "AvailabilityStatus",
    "Capabilities",
    "CliqueModel",
    "ExactSolver",
    "LoadedSolver",
    "MinimumExpressions",
    "OpenExpression",
    "OrderedSequence",
    "Proposal",
    "RefiningSolver",
    "Result",
    "Solver",
    "SolverInfo",
    "SolverUnavailableError",
    "UnknownSolverError",
    "availability",
    "get",
    "info",
    "load",
    "minimum_cover_solvers",
    "minimum_expressions",
    "names",
    "ordered_minimum_sequence",
    "package_availability",
    "refine",
    "refresh",
    "rejecting",
    "solver_class",
]


def __getattr__(name: str) -> Any:
    """Import a public name from its module on first use and keep it in the package namespace."""
    module = _MODULE_OF.get(name)
    if module is None:
        raise AttributeError(f"module 'solvers' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
