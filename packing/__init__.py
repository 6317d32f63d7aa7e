"""Expression packing (Carrigan et al. 2020, sec. 4): binary blendshapes, importance, symmetry, the
packing problem and its presolve, the expression sequence (Algorithm 1) and the independent checker."""

from packing._problem import PackingProblem, problem_from_incidence
from packing._solution import Solution, SolutionStatus, Termination

__all__ = [
    "PackingProblem",
    "Solution",
    "SolutionStatus",
    "Termination",
    "problem_from_incidence",
]
