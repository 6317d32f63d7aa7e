"""Expression packing (Carrigan et al. 2020, sec. 4): binary blendshapes, importance, symmetry, the
packing problem and its presolve, the expression sequence (Algorithm 1), the independent checker, and the
three as one checked pipeline (`Pipeline`).

Names are imported from their modules on first use (PEP 562): ``from packing import PackingProblem``
(what a solver plugin needs) loads neither the rig analysis, nor the rig loaders, nor networkx."""

from __future__ import annotations

from typing import TYPE_CHECKING

import lazy_loader

if TYPE_CHECKING:
    from packing._analysis import TIE_BREAK_SCALE, Analysis, analyse, build_problem, tie_break_perturbation
    from packing._binary import binary_blendshapes, empty_shapes
    from packing._bounds import (
        ExpressionBound,
        conflict_graph,
        conflict_set_bound,
        expression_lower_bound,
        first_fit_colouring,
    )
    from packing._cancel import CANCEL_RATIO, Cancellation, cancelling_twins, find_cancellations
    from packing._check import CheckError, check
    from packing._constraints import parse_pair, read_constraints
    from packing._face_rules import FaceRule, MatchedRules, match_rules, read_rules
    from packing._importance import DegenerateDistortionWarning, MissingTargetWarning, importance
    from packing._params import DEFAULT_REGION_PAIRS, PackingParams
    from packing._pipeline import Pipeline, failed_expression
    from packing._presolve import ConflictSets, ConflictView, pack_bit_rows, unpack_bit_rows
    from packing._problem import PackingProblem, problem_from_incidence
    from packing._sequence import PackingSolver, sequence
    from packing._solution import EXPRESSION_TIMES, Expression, Solution, SolutionStatus, Termination
    from packing._symmetry import SymmetryResult, find_symmetry_pairs

__getattr__, __dir__, __all__ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "_analysis": ["TIE_BREAK_SCALE", "Analysis", "analyse", "build_problem", "tie_break_perturbation"],
        "_binary": ["binary_blendshapes", "empty_shapes"],
        "_face_rules": ["FaceRule", "MatchedRules", "match_rules", "read_rules"],
        "_bounds": [
            "conflict_set_bound",
            "ExpressionBound",
            "first_fit_colouring",
            "conflict_graph",
            "expression_lower_bound",
        ],
        "_cancel": ["CANCEL_RATIO", "Cancellation", "cancelling_twins", "find_cancellations"],
        "_check": ["CheckError", "check"],
        "_constraints": ["parse_pair", "read_constraints"],
        "_importance": ["DegenerateDistortionWarning", "MissingTargetWarning", "importance"],
        "_params": ["DEFAULT_REGION_PAIRS", "PackingParams"],
        "_presolve": ["ConflictSets", "ConflictView", "pack_bit_rows", "unpack_bit_rows"],
        "_pipeline": ["Pipeline", "failed_expression"],
        "_problem": ["PackingProblem", "problem_from_incidence"],
        "_sequence": ["PackingSolver", "sequence"],
        "_solution": ["EXPRESSION_TIMES", "Expression", "Solution", "SolutionStatus", "Termination"],
        "_symmetry": ["SymmetryResult", "find_symmetry_pairs"],
    },
)
