"""The public names of `packing`, read by type checkers and by its lazy loader (`lazy_loader.attach_stub`):
each is imported from its module on first use."""

from ._analysis import (
    TIE_BREAK_SCALE as TIE_BREAK_SCALE,
    Analysis as Analysis,
    analyse as analyse,
    build_problem as build_problem,
    tie_break_perturbation as tie_break_perturbation,
)
from ._binary import (
    binary_blendshapes as binary_blendshapes,
    empty_shapes as empty_shapes,
)
from ._bounds import (
    ExpressionBound as ExpressionBound,
    conflict_graph as conflict_graph,
    conflict_set_bound as conflict_set_bound,
    expression_lower_bound as expression_lower_bound,
    first_fit_colouring as first_fit_colouring,
)
from ._cancel import (
    CANCEL_RATIO as CANCEL_RATIO,
    Cancellation as Cancellation,
    cancelling_twins as cancelling_twins,
    find_cancellations as find_cancellations,
)
from ._check import (
    CheckError as CheckError,
    check as check,
)
from ._constraints import (
    parse_pair as parse_pair,
    read_constraints as read_constraints,
)
from ._face_rules import (
    FaceRule as FaceRule,
    MatchedRules as MatchedRules,
    match_rules as match_rules,
    read_rules as read_rules,
)
from ._importance import (
    DegenerateDistortionWarning as DegenerateDistortionWarning,
    MissingTargetWarning as MissingTargetWarning,
    importance as importance,
)
from ._params import (
    DEFAULT_REGION_PAIRS as DEFAULT_REGION_PAIRS,
    PackingParams as PackingParams,
)
from ._pipeline import (
    Pipeline as Pipeline,
    failed_expression as failed_expression,
)
from ._presolve import (
    ConflictSets as ConflictSets,
    ConflictView as ConflictView,
    pack_bit_rows as pack_bit_rows,
    unpack_bit_rows as unpack_bit_rows,
)
from ._problem import (
    PackingProblem as PackingProblem,
    problem_from_incidence as problem_from_incidence,
)
from ._sequence import (
    PackingSolver as PackingSolver,
    sequence as sequence,
)
from ._solution import (
    EXPRESSION_TIMES as EXPRESSION_TIMES,
    Expression as Expression,
    Solution as Solution,
    SolutionStatus as SolutionStatus,
    Termination as Termination,
)
from ._symmetry import (
    SymmetryResult as SymmetryResult,
    find_symmetry_pairs as find_symmetry_pairs,
)
