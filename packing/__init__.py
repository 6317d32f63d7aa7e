"""Expression packing (Carrigan et al. 2020, sec. 4): binary blendshapes, importance, symmetry, the
packing problem and its presolve, the expression sequence (Algorithm 1) and the independent checker."""

from packing._analysis import Analysis, analyse, build_problem, tie_break_perturbation
from packing._binary import binary_blendshapes, empty_shapes
from packing._bounds import ExpressionBound, conflict_graph, expression_lower_bound
from packing._cancel import CANCEL_RATIO, Cancellation, cancelling_twins, find_cancellations
from packing._check import CheckError, check
from packing._constraints import parse_pair, read_constraints
from packing._importance import DegenerateDistortionWarning, MissingTargetWarning, importance
from packing._params import DEFAULT_REGION_PAIRS, PackingParams
from packing._problem import PackingProblem, problem_from_incidence
from packing._sequence import Expression, PackingSolver, sequence
from packing._solution import Solution, SolutionStatus, Termination
from packing._symmetry import SymmetryResult, find_symmetry_pairs

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
    "find_cancellations",
    "find_symmetry_pairs",
    "importance",
    "parse_pair",
    "read_constraints",
    "problem_from_incidence",
    "sequence",
    "tie_break_perturbation",
]
