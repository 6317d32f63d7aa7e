"""The fewest expressions that cover every item, and the ordered sequence that keeps that count.

Beyond the paper: Algorithm 1 repeats eq. 3 until no blendshape is left, and the number of expressions
it needs is not minimal. Covering every item with the fewest expressions is a colouring of the item
conflict graph (two items conflict iff they share an active vertex or are kept apart, i.e. share a
presolved conflict set; a symmetry pair is one item), with at most ``cap`` blendshapes per colour when a
cap is set (sec. 6).

The colouring models (CP-SAT, or HiGHS as the MILP backend) are in `solvers._colouring`; a solver
plugin whose capabilities declare ``minimum_cover`` solves one (``solve_colouring``).

The *ordered minimum* sequence then maximises each expression's weight (eq. 3a, as Algorithm 1) subject
to the remaining items still fitting in the remaining expressions of the minimum count.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from packing import PackingProblem, SolutionStatus, Termination, conflict_set_bound, first_fit_colouring
from solvers import _registry as registry
from solvers._base import Stopwatch, check_solve_arguments
from solvers._colouring import add_colouring, hint_colours, largest_clique
from solvers._cpsat_run import integer_weights, solve_cp_model


@dataclass(frozen=True)
class MinimumExpressions:
    """The fewest expressions covering every item (a colouring of the conflict graph).

    Attributes
    ----------
    count : int
        Expressions in the best cover found (the minimum when ``termination`` is OPTIMAL).
    lower_bound : int
        Proved lower bound: the largest conflict set, the cap bound, or the solver's bound.
    expressions : tuple of tuple of int
        Items of each expression, heaviest expression first.
    termination : Termination
        OPTIMAL (count proved minimal) or TIME_LIMIT (count feasible, not proved).
    solve_time : float
        Seconds including model build.
    backend : str
    version : str
    """

    count: int
    lower_bound: int
    expressions: tuple[tuple[int, ...], ...]
    termination: Termination
    solve_time: float
    backend: str
    version: str

    @property
    def status(self) -> SolutionStatus:
        """OPTIMAL when the count is proved minimal, else FEASIBLE."""
        return SolutionStatus.OPTIMAL if self.termination is Termination.OPTIMAL else SolutionStatus.FEASIBLE


@dataclass(frozen=True)
class OrderedSequence:
    """Expressions that use the minimum count, each as heavy as that count allows.

    Attributes
    ----------
    expressions : tuple of tuple of int
        Items of each expression in sequence order.
    objectives : tuple of float
        Eq. 3a weight of each expression: its importance sum, without the tie-break (as
        `packing.Expression.objective`).
    terminations : tuple of Termination
        Per step: OPTIMAL when the step's weight is proved maximal under the count constraint.
    minimum : MinimumExpressions
        The cover whose count the sequence keeps.
    solve_time : float
    """

    expressions: tuple[tuple[int, ...], ...]
    objectives: tuple[float, ...]
    terminations: tuple[Termination, ...]
    minimum: MinimumExpressions
    solve_time: float


def _check_cap(problem: PackingProblem) -> None:
    counts = problem.item_shape_counts
    if problem.cap is not None and counts.size and counts.max() > problem.cap:
        item = int(np.argmax(counts))
        raise ValueError(
            f"item {problem.item_label(item)!r} has {counts[item]} blendshapes, more than the cap of "
            f"{problem.cap} per expression: no cover exists"
        )


def _classes(problem: PackingProblem, colour: np.ndarray) -> tuple[tuple[int, ...], ...]:
    """Items per colour, heaviest expression first (ties by smallest item)."""
    groups = [tuple(np.flatnonzero(colour == c).tolist()) for c in np.unique(colour)]
    return tuple(sorted(groups, key=lambda g: (-problem.objective(g), g)))


def minimum_expressions(
    problem: PackingProblem, *, solver: str = "cpsat", time_limit: float | None = None, seed: int = 0
) -> MinimumExpressions:
    """The fewest expressions that cover every item of ``problem``.

    Parameters
    ----------
    problem : PackingProblem
        All items (blendshapes and symmetry pairs) to cover, with the optional cap.
    solver : str
        A solver plugin whose capabilities declare ``minimum_cover`` (`minimum_cover_solvers`): CP-SAT,
        or HiGHS for the same model as a MILP.
    time_limit : float, optional
        Seconds for the solver; when reached, the best cover found is returned with TIME_LIMIT.
    seed : int

    Returns
    -------
    MinimumExpressions

    Raises
    ------
    ValueError
        Unknown ``solver``, or an item with more blendshapes than the cap.

    Examples
    --------
    >>> import numpy as np
    >>> from packing import problem_from_incidence
    >>> problem = problem_from_incidence(np.array([[1, 1, 0], [0, 1, 1], [1, 0, 1]]), [1.0, 1.0, 1.0])
    >>> minimum_expressions(problem).count  # a triangle of conflicts needs 3 expressions
    3
    """
    check_solve_arguments(problem, time_limit, seed)
    plugin = _covering_plugin(solver)
    _check_cap(problem)
    clock = Stopwatch()
    lower = conflict_set_bound(problem)
    if problem.n_items == 0:
        return MinimumExpressions(0, 0, (), Termination.OPTIMAL, 0.0, solver, "")
    start = first_fit_colouring(problem)
    n_colours = int(start.max()) + 1
    if n_colours == lower:
        version = plugin.availability().version
        return MinimumExpressions(
            n_colours, lower, _classes(problem, start), Termination.OPTIMAL, clock.lap(), solver, version
        )
    colour, bound, proved, version = plugin.solve_colouring(
        problem, start, lower, time_limit=time_limit, seed=seed
    )
    count = int(colour.max()) + 1
    lower = max(lower, bound)
    termination = Termination.OPTIMAL if proved or count == lower else Termination.TIME_LIMIT
    return MinimumExpressions(
        count, lower, _classes(problem, colour), termination, clock.lap(), solver, version
    )


def minimum_cover_solvers() -> list[str]:
    """Installed, available solver plugins whose capabilities declare ``minimum_cover``."""
    return [
        name
        for name in registry.names()
        if registry.availability(name) and registry.solver_class(name).capabilities.minimum_cover
    ]


def _covering_plugin(name: str):
    """An instance of solver ``name``, which must declare ``minimum_cover``."""
    plugin = registry.get(name).plugin
    if not plugin.capabilities.minimum_cover:
        raise ValueError(
            f"minimum_expressions: solver {name!r} cannot prove the fewest expressions; "
            f"use one of {', '.join(minimum_cover_solvers())}"
        )
    return plugin


def ordered_minimum_sequence(
    problem: PackingProblem,
    *,
    time_limit: float | None = None,
    seed: int = 0,
    minimum: MinimumExpressions | None = None,
) -> OrderedSequence:
    """Algorithm 1's priority order within the minimum number of expressions (CP-SAT).

    Step j maximises eq. 3a over the remaining items, subject to the items left after it still being
    coverable by the ``m - j - 1`` remaining expressions, where ``m`` is ``minimum.count``. The previous
    step's cover is a feasible start, so every step has a solution and the sequence has exactly m
    expressions. Weights are the problem's, fixed for the whole sequence.

    Parameters
    ----------
    problem : PackingProblem
    time_limit : float, optional
        Seconds per step (and for the minimum, when it is computed here).
    seed : int
    minimum : MinimumExpressions, optional
        A cover computed before; default ``minimum_expressions(problem, solver="cpsat", ...)``.

    Returns
    -------
    OrderedSequence
    """
    from ortools.sat.python import cp_model

    check_solve_arguments(problem, time_limit, seed)
    clock = Stopwatch()
    if minimum is None:
        minimum = minimum_expressions(problem, time_limit=time_limit, seed=seed)
    cover = [list(group) for group in minimum.expressions]  # a valid cover of the remaining items
    remaining = np.arange(problem.n_items)
    expressions, objectives, terminations = [], [], []
    for step in range(minimum.count):
        left = minimum.count - step
        if left == 1:
            chosen, termination = remaining.tolist(), Termination.OPTIMAL
        else:
            chosen, cover, termination = _heaviest_step(
                cp_model, problem, remaining, cover, left, time_limit, seed
            )
        expressions.append(tuple(sorted(chosen)))
        objectives.append(problem.unperturbed_objective(chosen))
        terminations.append(termination)
        remaining = np.setdiff1d(remaining, chosen)
    return OrderedSequence(tuple(expressions), tuple(objectives), tuple(terminations), minimum, clock.lap())


def _heaviest_step(cp_model, problem, remaining, cover, left, time_limit, seed):
    """Heaviest expression among ``remaining`` whose rest fits in ``left - 1`` expressions.

    Returns the chosen items, a cover of the rest by ``left - 1`` expressions (the next step's start)
    and the step's termination.
    """
    sub = problem.restrict(remaining)
    shortcut = _unconstrained_step(problem, sub, remaining, left, time_limit, seed)
    if shortcut is not None:
        return shortcut
    position = {int(item): k for k, item in enumerate(remaining.tolist())}
    ordered = np.concatenate([largest_clique(sub), np.arange(sub.n_items)])
    ordered = ordered[np.sort(np.unique(ordered, return_index=True)[1])]
    model = cp_model.CpModel()
    x = [[model.new_bool_var(f"x{i}_{c}") for c in range(left)] for i in range(sub.n_items)]
    add_colouring(model, cp_model, sub, x, left, None)
    for rank, item in enumerate(ordered.tolist()):  # colours 1.. are interchangeable: first-use order
        for c in range(rank + 2, left):
            model.add(x[item][c] == 0)
    scaled, _ = integer_weights(sub.weights)
    model.maximize(cp_model.LinearExpr.weighted_sum([row[0] for row in x], scaled.tolist()))
    hint = np.empty(sub.n_items, dtype=np.int64)
    for c, group in enumerate(cover):
        hint[[position[i] for i in group]] = c
    hint_colours(model, x, _first_use_order(hint, ordered), left)
    solver, status = solve_cp_model(model, time_limit, seed)
    if status not in (cp_model.OPTIMAL, cp_model.FEASIBLE):
        return list(cover[0]), [list(group) for group in cover[1:]], Termination.TIME_LIMIT
    colour = np.array(
        [next(c for c in range(left) if solver.boolean_value(x[i][c])) for i in range(sub.n_items)]
    )
    chosen = remaining[colour == 0].tolist()
    rest = [remaining[colour == c].tolist() for c in range(1, left)]
    termination = Termination.OPTIMAL if status == cp_model.OPTIMAL else Termination.TIME_LIMIT
    return chosen, [group for group in rest if group], termination


def _unconstrained_step(problem, sub, remaining, left, time_limit, seed):
    """The plain optimum of eq. 3 when its rest provably fits in ``left - 1`` expressions, else None.

    The constrained optimum is at most the unconstrained one, so an unconstrained optimum that
    satisfies the count constraint is the step's answer; a first-fit cover, or a cover found by
    `minimum_expressions` within the time limit, proves that it does.
    """
    from solvers._loaded import load
    from solvers.cpsat import CpSatSolver

    solution = load(CpSatSolver).solve(sub, time_limit=time_limit, seed=seed)
    if solution.termination is not Termination.OPTIMAL:
        return None
    rest_index = np.setdiff1d(np.arange(sub.n_items), solution.items)
    chosen = remaining[list(solution.items)].tolist()
    if rest_index.size == 0:
        return chosen, [], Termination.OPTIMAL
    rest = sub.restrict(rest_index)
    colour = first_fit_colouring(rest)
    if colour.max() + 1 > left - 1:
        cover = minimum_expressions(rest, time_limit=time_limit, seed=seed)
        if cover.count > left - 1:
            return None
        groups = [remaining[rest_index[list(group)]].tolist() for group in cover.expressions]
    else:
        groups = [remaining[rest_index[colour == c]].tolist() for c in range(colour.max() + 1)]
    return chosen, groups, Termination.OPTIMAL


def _first_use_order(colour: np.ndarray, ordered: np.ndarray) -> np.ndarray:
    """Relabel colours 1.. by first use along ``ordered`` (colour 0 stays), matching the symmetry rows."""
    mapping = {0: 0}
    for item in ordered.tolist():
        mapping.setdefault(int(colour[item]), len(mapping))
    return np.array([mapping[int(c)] for c in colour])
