"""Solver backends for expression packing (Carrigan et al. 2020, sec. 4.5) behind one plugin interface.

Solvers are plugins registered in the ``harness.solvers`` entry-point group; `names` lists them without
importing any backend, `get` returns a ready instance, `info` reports availability and capabilities.
Beyond single expressions: artist refinement (sec. 4.5.3, `refine`, `RefiningSolver`) and the minimum
number of expressions with its ordered sequence (`minimum_expressions`, `ordered_minimum_sequence`).
The conformance checks for plugins live in `solvers.testing`.

Names are imported from their modules on first use (PEP 562): listing the plugins imports neither a
backend nor the minimum-expression machinery.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from solvers._base import Availability, AvailabilityStatus, Capabilities, Solver
    from solvers._minimum import (
        MinimumExpressions,
        OrderedSequence,
        minimum_expressions,
        ordered_minimum_sequence,
    )
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
    )

#: The module that defines each public name.
_MODULE_OF = {
    "Availability": "solvers._base",
    "AvailabilityStatus": "solvers._base",
    "Capabilities": "solvers._base",
    "Solver": "solvers._base",
    "MinimumExpressions": "solvers._minimum",
    "OrderedSequence": "solvers._minimum",
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
}

__all__ = [
    "Availability",
    "AvailabilityStatus",
    "Capabilities",
    "MinimumExpressions",
    "OrderedSequence",
    "Proposal",
    "RefiningSolver",
    "Solver",
    "SolverInfo",
    "SolverUnavailableError",
    "UnknownSolverError",
    "availability",
    "get",
    "info",
    "minimum_expressions",
    "names",
    "ordered_minimum_sequence",
    "refine",
    "refresh",
    "rejecting",
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
