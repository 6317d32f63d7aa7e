"""Solver backends for expression packing (Carrigan et al. 2020, sec. 4.5) behind one plugin interface.

Solvers are plugins registered in the ``harness.solvers`` entry-point group; `names` lists them without
importing any backend, `get` returns a ready instance, `info` reports availability and capabilities.
Beyond single expressions: artist refinement (sec. 4.5.3, `refine`, `RefiningSolver`) and the minimum
number of expressions with its ordered sequence (`minimum_expressions`, `ordered_minimum_sequence`).
The conformance checks for plugins live in `solvers.testing`.
"""

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
