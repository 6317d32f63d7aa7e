"""Expression packing (Carrigan et al. 2020, sec. 4): binary blendshapes, importance, symmetry, the
packing problem and its presolve, the expression sequence (Algorithm 1) and the independent checker.

Names are imported from their modules on first use (PEP 562): ``from packing import PackingProblem``
(what a solver plugin needs) loads neither the rig analysis, nor the rig loaders, nor networkx."""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from packing._analysis import Analysis, analyse, build_problem, tie_break_perturbation
    from packing._binary import binary_blendshapes, empty_shapes
    from packing._bounds import ExpressionBound, conflict_graph, expression_lower_bound, first_fit_colouring
    from packing._cancel import CANCEL_RATIO, Cancellation, cancelling_twins, find_cancellations
    from packing._check import CheckError, check
    from packing._constraints import parse_pair, read_constraints
    from packing._importance import DegenerateDistortionWarning, MissingTargetWarning, importance
    from packing._params import DEFAULT_REGION_PAIRS, PackingParams
    from packing._problem import PackingProblem, problem_from_incidence
    from packing._sequence import Expression, PackingSolver, sequence
    from packing._solution import Solution, SolutionStatus, Termination
    from packing._symmetry import SymmetryResult, find_symmetry_pairs

#: The module that defines each public name.
_MODULE_OF = {
    "Analysis": "packing._analysis",
    "analyse": "packing._analysis",
    "build_problem": "packing._analysis",
    "tie_break_perturbation": "packing._analysis",
    "binary_blendshapes": "packing._binary",
    "empty_shapes": "packing._binary",
    "ExpressionBound": "packing._bounds",
    "first_fit_colouring": "packing._bounds",
    "conflict_graph": "packing._bounds",
    "expression_lower_bound": "packing._bounds",
    "CANCEL_RATIO": "packing._cancel",
    "Cancellation": "packing._cancel",
    "cancelling_twins": "packing._cancel",
    "find_cancellations": "packing._cancel",
    "CheckError": "packing._check",
    "check": "packing._check",
    "parse_pair": "packing._constraints",
    "read_constraints": "packing._constraints",
    "DegenerateDistortionWarning": "packing._importance",
    "MissingTargetWarning": "packing._importance",
    "importance": "packing._importance",
    "DEFAULT_REGION_PAIRS": "packing._params",
    "PackingParams": "packing._params",
    "PackingProblem": "packing._problem",
    "problem_from_incidence": "packing._problem",
    "Expression": "packing._sequence",
    "PackingSolver": "packing._sequence",
    "sequence": "packing._sequence",
    "Solution": "packing._solution",
    "SolutionStatus": "packing._solution",
    "Termination": "packing._solution",
    "SymmetryResult": "packing._symmetry",
    "find_symmetry_pairs": "packing._symmetry",
}

__all__ = [
    "CANCEL_RATIO",
    "Cancellation",
    "DEFAULT_REGION_PAIRS",
    "Analysis",
    "CheckError",
    "Expression",
    "ExpressionBound",
    "DegenerateDistortionWarning",
    "MissingTargetWarning",
    "PackingParams",
    "PackingProblem",
    "PackingSolver",
    "Solution",
    "SolutionStatus",
    "SymmetryResult",
    "Termination",
    "analyse",
    "binary_blendshapes",
    "build_problem",
    "cancelling_twins",
    "check",
    "empty_shapes",
    "conflict_graph",
    "expression_lower_bound",
    "first_fit_colouring",
    "find_cancellations",
    "find_symmetry_pairs",
    "importance",
    "parse_pair",
    "read_constraints",
    "problem_from_incidence",
    "sequence",
    "tie_break_perturbation",
]


def __getattr__(name: str) -> Any:
    """Import a public name from its module on first use and keep it in the package namespace."""
    module = _MODULE_OF.get(name)
    if module is None:
        raise AttributeError(f"module 'packing' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
