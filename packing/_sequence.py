"""The expression sequence (Carrigan et al. 2020, Algorithm 1) with the extensions of sec. 6."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace
from typing import Any, Protocol

import numpy as np

from packing._analysis import Analysis, analyse
from packing._problem import PackingProblem, with_meta
from packing._solution import Expression, Solution
from rigs import Rig


class PackingSolver(Protocol):
    """What `sequence` needs from a solver: an object whose ``solve`` answers with a whole `Solution`, as a
    plugin behind the `solvers` framework does (``solvers.get(name)`` or ``solvers.load(plugin)``)."""

    def solve(
        self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0
    ) -> Solution: ...


def sequence(
    rig: Rig,
    solver: PackingSolver,
    *,
    target_neutral: Rig | np.ndarray | None = None,
    jmax: int | None = None,
    time_limit: float | None = None,
    seed: int = 0,
    analysis: Analysis | None = None,
    on_expression: Callable[[Expression], None] | None = None,
    **params: Any,
) -> list[Expression]:
    """Reference expressions one after another (Carrigan et al. 2020, Algorithm 1).

    Each iteration solves eq. 3 over the items not used yet, with importance recomputed (the
    uniqueness term of eq. 8 when ``beta > 0``), and removes the chosen items. The loop stops when
    every non-empty shape is used *or* ``jmax`` expressions exist (the paper's "or" in the loop
    condition is a typo for "and" of the negations), or when the solver returns nothing. Each problem
    is derived from the previous one's presolved conflict sets (`Analysis.next_problem`, docs/architecture.md:
    the sequence re-solves a shrinking problem); only the analysis visits the vertices.

    Parameters
    ----------
    rig : Rig
        The template rig.
    solver : object with ``solve(problem, *, time_limit, seed) -> Solution``
        A solver behind the `solvers` framework (``solvers.get(name)``, ``solvers.load(plugin)``), whose
        answers are whole `Solution` objects; `packing` never imports a solver library.
    target_neutral : (N, 3) array or Rig, optional
        Target neutral for triangle distortion (eqs. 6-7).
    jmax : int, optional
        Maximum number of expressions (J_max); default until every shape is used.
    time_limit : float, optional
        Seconds per solve, passed to the solver.
    seed : int
        Passed to the solver.
    analysis : Analysis, optional
        A ready analysis of ``rig`` (e.g. shared by several solvers); then no ``target_neutral`` or
        ``params`` may be given.
    on_expression : callable, optional
        Called with each expression as soon as it is finished, before the next solve starts (a caller that
        may be stopped mid-sequence keeps the expressions found so far this way).
    **params
        `PackingParams` fields, among them ``max_per_expression`` (cap, sec. 6) and
        ``extra_examples`` (the second pass of sec. 6: after each expression, the solver packs
        already-used items that fit beside it without overlap and within the cap, weighted by
        importance without the uniqueness term; they are recorded in ``extra_examples``).

    Returns
    -------
    list of Expression

    Raises
    ------
    ValueError
        For bad parameters, or a solver answer naming items the problem does not have.
    """
    if analysis is None:
        analysis = analyse(rig, target_neutral, **params)
    elif params or target_neutral is not None:
        raise ValueError("sequence: give either analysis or target_neutral/params, not both")
    elif analysis.rig.names != rig.names or analysis.rig.neutral.shape != rig.neutral.shape:
        raise ValueError(
            f"sequence: the analysis was made for rig {analysis.rig.provenance.source or '?'!r}, "
            f"not for {rig.provenance.source or '?'!r}"
        )
    if jmax is not None and (isinstance(jmax, bool) or not isinstance(jmax, int) or jmax < 0):
        raise ValueError(f"jmax must be a non-negative integer or None, got {jmax!r}")

    names = analysis.rig.names
    remaining = int(np.count_nonzero(analysis.packable))
    used: list[str] = []
    used_items: list[int] = []
    expressions: list[Expression] = []
    problem: PackingProblem | None = None
    chosen = np.zeros(0, dtype=np.int64)
    while remaining > 0 and (jmax is None or len(expressions) < jmax):
        start = time.perf_counter()
        problem = analysis.problem_for() if problem is None else analysis.next_problem(problem, chosen, used)
        problem = with_meta(problem, expression=len(expressions) + 1, stage="primary")
        presolve_time = time.perf_counter() - start
        solution = solver.solve(problem, time_limit=time_limit, seed=seed)
        chosen = _chosen_items(problem, solution)
        full_items = problem.meta["item_index"][chosen]
        shapes = tuple(names[k] for i in full_items for k in analysis.problem.items[i])
        extra, extra_time = (), 0.0
        if analysis.params.extra_examples and used_items and chosen.size:
            extra, extra_time = _extra_examples(
                analysis, solver, used_items, full_items, time_limit, seed, len(expressions) + 1
            )
        expressions.append(
            Expression(
                index=len(expressions) + 1,
                shapes=shapes,
                items=tuple(problem.item_label(i) for i in chosen),
                objective=problem.unperturbed_objective(chosen),
                solution=solution,
                presolve_time=presolve_time,
                n_items=problem.n_items,
                vertex_rows=problem.n_vertex_rows,
                clique_rows=problem.deferred_n_cliques(),
                extra_examples=extra,
                extra_time=extra_time,
            )
        )
        if on_expression is not None:
            on_expression(expressions[-1])
        if not shapes:
            break
        used.extend(shapes)
        used_items.extend(int(i) for i in full_items)
        remaining -= len(shapes)
    return expressions


def _chosen_items(problem: PackingProblem, solution: Solution) -> np.ndarray:
    if not isinstance(solution, Solution):
        raise TypeError(
            f"sequence: the solver answered with a {type(solution).__name__}, not a packing.Solution; "
            "pass solvers.get(name) or solvers.load(plugin), which turn a plugin's answer into one"
        )
    chosen = np.array(sorted({int(item) for item in solution.items}), dtype=np.int64)
    if chosen.size and (chosen[0] < 0 or chosen[-1] >= problem.n_items):
        raise ValueError(
            f"solver {solution.backend or '?'} returned items {list(solution.items)} "
            f"outside 0..{problem.n_items - 1}"
        )
    return chosen


def _extra_examples(
    analysis: Analysis,
    solver: PackingSolver,
    used_items: list[int],
    chosen: np.ndarray,
    time_limit: float | None,
    seed: int,
    index: int,
) -> tuple[tuple[str, ...], float]:
    """Sec. 6 second pass: already-used items that fit beside the expression's chosen items (no shared
    vertex, not apart from any of them, within the cap). The problem's meta names the expression ``index``
    and ``stage="extra_examples"``, so a wrapper such as artist refinement can tell the two solves of one
    expression from the solves of two expressions."""
    full = analysis.problem
    cap = full.cap
    room = None if cap is None else cap - int(full.item_shape_counts[chosen].sum())
    if room is not None and room <= 0:
        return (), 0.0
    occupied = np.asarray(full.incidence[chosen].sum(axis=0)).ravel() > 0
    candidates = np.array(sorted(set(used_items)), dtype=np.int64)
    clash = full.incidence[candidates] @ occupied.astype(np.float64)
    candidates = candidates[clash == 0]
    taken = set(chosen.tolist())
    barred = [b if a in taken else a for a, b in full.apart if a in taken or b in taken]
    candidates = candidates[~np.isin(candidates, barred)]
    if room is not None:
        candidates = candidates[full.item_shape_counts[candidates] <= room]
    if candidates.size == 0:
        return (), 0.0
    problem = full.reweighted(analysis.item_weights()).restrict(candidates)
    problem = with_meta(replace(problem, cap=room), expression=index, stage="extra_examples")
    solution = solver.solve(problem, time_limit=time_limit, seed=seed)
    extra = _chosen_items(problem, solution)
    names = tuple(analysis.rig.names[k] for i in candidates[extra] for k in full.items[i])
    return names, solution.build_time + solution.solve_time
