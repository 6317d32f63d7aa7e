"""Artist-friendly refinement (Carrigan et al. 2020, sec. 4.5.3).

"As each blendshape is chosen, the user is presented with the options to accept or reject it. If
blendshapes are rejected, the algorithm proposes alternative nearly optimal blendshapes and the process
is repeated. All rejected blendshapes are no longer considered for the current expression, but will be
reconsidered when computing the next expression."

`refine` does this with any solver: it solves the expression, proposes the chosen items one at a time
(heaviest first) to a ``decide`` callback, keeps accepted items, and after a rejection re-solves over the
items that are neither decided nor in conflict with an accepted one (`PackingProblem.restrict`), with the
cap reduced by the accepted shapes. `RefiningSolver` wraps this as a `Solver`, so the expression sequence
(Algorithm 1) runs it per expression and rejections never carry over; the second pass of sec. 6 (extra
examples) is refined as part of the expression it completes.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Collection, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from packing import Solution, Termination
from solvers._base import Capabilities, check_solve_arguments, make_solution
from solvers._loaded import load

if TYPE_CHECKING:
    from packing import PackingProblem


@dataclass(frozen=True)
class Proposal:
    """One item put to the artist.

    Attributes
    ----------
    problem : PackingProblem
        The expression's whole problem; ``item`` and ``accepted`` index its items.
    item : int
    label : str
        Shape name, or ``left+right`` for a symmetry pair.
    shapes : tuple of str
    weight : float
        The item's weight in eq. 3a.
    accepted : tuple of int
        Items accepted so far in this expression.
    expression : int
        Index of the expression in the sequence (0 for the first), as `RefiningSolver` tells it.
    extra_example : bool
        The item is proposed as an extra example (the second pass of sec. 6: a shape already used by an
        earlier expression, added again where it fits).
    """

    problem: PackingProblem
    item: int
    label: str
    shapes: tuple[str, ...]
    weight: float
    accepted: tuple[int, ...]
    expression: int
    extra_example: bool = False


#: The artist's decision: True accepts the proposed item, False rejects it for this expression.
Decide = Callable[[Proposal], bool]


def refine(
    problem: PackingProblem,
    solver,
    decide: Decide,
    *,
    time_limit: float | None = None,
    seed: int = 0,
    expression: int = 0,
    extra_example: bool = False,
) -> Solution:
    """One expression with artist accept/reject decisions (sec. 4.5.3).

    Parameters
    ----------
    problem : PackingProblem
    solver : Solver
        Solves each (re)proposal; any plugin.
    decide : callable(Proposal) -> bool
        Called once per proposed item, best (heaviest) first.
    time_limit, seed
        Passed to every solve.
    expression : int
        Expression index reported in the proposals.
    extra_example : bool
        Reported in the proposals: ``problem`` is the extra-example pass of the expression (sec. 6).

    Returns
    -------
    Solution
        The accepted items. ``termination`` is the inner solver's when nothing was rejected (an optimal
        inner solve gives the optimum). After rejections it is OPTIMAL when every (re)solve was optimal:
        each re-solve is optimal over the items neither decided nor in conflict with an accepted one, so
        the result is optimal among the packings that keep the accepted items and avoid the rejected
        ones (the problem restricted by the artist's decisions); else COMPLETED. TIME_LIMIT if any solve
        hit the limit, ERROR if one failed. ``message`` lists the rejected items.
    """
    check_solve_arguments(problem, time_limit, seed)
    solver = load(solver)
    from packing import conflict_graph

    adjacency = conflict_graph(problem)
    counts = problem.item_shape_counts
    accepted: list[int] = []
    blocked = np.zeros(problem.n_items, dtype=bool)  # decided, or conflicting with an accepted item
    rejected: list[int] = []
    pending: list[int] = []
    terminations: list[Termination] = []
    fallback = ""  # the first (re)solve whose items came from a fallback names it
    build_time = solve_time = 0.0
    version = ""
    while True:
        if not pending:
            candidates = np.flatnonzero(~blocked)
            room = None if problem.cap is None else problem.cap - int(counts[accepted].sum())
            if candidates.size == 0 or (room is not None and room < 1):
                break
            sub = problem.restrict(candidates)
            if room is not None:
                sub = dataclasses.replace(sub, cap=room)
            solution = solver.solve(sub, time_limit=time_limit, seed=seed)
            build_time += solution.build_time
            solve_time += solution.solve_time
            version = solution.version
            terminations.append(solution.termination)
            fallback = fallback or solution.fallback
            if solution.termination is Termination.ERROR:
                return make_solution(
                    problem, accepted, termination=Termination.ERROR, bound=None, build_time=build_time,
                    solve_time=solve_time, backend=f"{solver.name}+refine", version=version,
                    message=solution.message,
                )  # fmt: skip
            proposed = candidates[list(solution.items)]
            pending = proposed[np.lexsort((proposed, -problem.weights[proposed]))].tolist()
            if not pending:
                break
        item = pending.pop(0)
        blocked[item] = True
        proposal = Proposal(
            problem=problem,
            item=item,
            label=problem.item_label(item),
            shapes=tuple(problem.shape_names[k] for k in problem.items[item]),
            weight=float(problem.weights[item]),
            accepted=tuple(accepted),
            expression=expression,
            extra_example=extra_example,
        )
        if decide(proposal):
            accepted.append(item)
            blocked[adjacency.indices[adjacency.indptr[item] : adjacency.indptr[item + 1]]] = True
        else:
            rejected.append(item)
            pending = []  # re-solve without it: the rest of the proposal may no longer be best
    if Termination.TIME_LIMIT in terminations:
        termination = Termination.TIME_LIMIT
    elif not rejected:  # the first solve's items were all accepted
        termination = terminations[0] if terminations else Termination.OPTIMAL
    elif all(done is Termination.OPTIMAL for done in terminations):
        termination = Termination.OPTIMAL  # for the problem restricted by the decisions
    else:
        termination = Termination.COMPLETED
    message = ""
    if rejected:
        message = "rejected: " + ", ".join(problem.item_label(i) for i in rejected)
        if termination is Termination.OPTIMAL:
            message += " (optimal without the rejected items, with the accepted ones)"
    return make_solution(
        problem,
        accepted,
        termination=termination,
        bound=None,
        build_time=build_time,
        solve_time=solve_time,
        backend=f"{solver.name}+refine",
        version=version,
        message=message,
        fallback=fallback,
    )


class RefiningSolver:
    """A `Solver` that runs `refine` with an inner solver and a decision callback, per expression.

    Each expression of the sequence (Algorithm 1) is refined on its own: rejections apply to that
    expression only. The expression comes from the problem: `packing.sequence` names it in
    ``meta["expression"]`` (1-based) for both solves of an expression, the primary one and the second pass
    of sec. 6 (``meta["stage"] == "extra_examples"``, whose proposals are marked ``extra_example``). A
    problem without that entry is the next expression: calls are counted. The index passed to ``decide``
    counts expressions from 0.

    Parameters
    ----------
    inner : Solver
    decide : callable(Proposal) -> bool
    """

    def __init__(self, inner, decide: Decide) -> None:
        self.inner = load(inner)
        self.decide = decide
        self.name = f"{inner.name}+refine"
        self.capabilities: Capabilities = dataclasses.replace(inner.capabilities, exact=False)
        self._calls = 0

    def availability(self):
        """The inner solver's availability."""
        return self.inner.availability()

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Solution:
        """Refine one expression of the sequence, or the extra examples of one."""
        named = problem.meta.get("expression")
        expression = self._calls if named is None else int(named) - 1
        self._calls += 1
        return refine(
            problem,
            self.inner,
            self.decide,
            time_limit=time_limit,
            seed=seed,
            expression=expression,
            extra_example=problem.meta.get("stage") == "extra_examples",
        )


def rejecting(rejections: Mapping[int, Collection[str]]) -> Decide:
    """A non-interactive ``decide`` that rejects the named shapes in the given expressions.

    Parameters
    ----------
    rejections : mapping of expression index (0-based) to shape names
        A proposal is rejected when its label or any of its shapes is named for its expression, as a
        primary shape or an extra example (rejecting one shape of a symmetry pair rejects the pair).

    Examples
    --------
    >>> decide = rejecting({0: {"jawOpen"}})  # the CLI's ``--reject 1:jawOpen``
    """
    named = {int(expression): frozenset(names) for expression, names in rejections.items()}

    def decide(proposal: Proposal) -> bool:
        names = named.get(proposal.expression, frozenset())
        return proposal.label not in names and names.isdisjoint(proposal.shapes)

    return decide
