"""The fewest expressions that cover every item as a colouring model, solved by CP-SAT (`colour_cpsat`) or by
HiGHS as a MILP (`colour_highs`): what the ``solve_colouring`` of the ``cpsat`` and ``highs`` plugins
answer for `solvers.minimum_expressions`, which also builds its ordered sequence's steps from these rows.

The models assign item i to colour c by a Boolean ``x[i, c]``: exactly one colour per item; for every
conflict set and colour ``sum x[i, c] <= used[c]`` (the clique rows, far stronger than pairwise edges);
``used[c] >= used[c + 1]``; the cap row per colour. The items of the largest conflict set get distinct
fixed colours (symmetry breaking), and its size is the lower bound. A first-fit colouring gives the number
of colours to model and the starting solution.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from packing import PackingProblem
from solvers._base import distribution_version
from solvers._cpsat_run import solve_cp_model


def largest_clique(problem: PackingProblem) -> np.ndarray:
    """The items of the largest conflict set (the first of those as large): they take distinct colours."""
    return max(problem.cliques, key=lambda c: (c.size, -c[0])) if problem.cliques else np.zeros(0, np.int64)


def colour_cpsat(problem, start, lower, time_limit, seed):
    """The colouring model in CP-SAT: (colours, proved lower bound, proved optimal, version)."""
    from ortools.sat.python import cp_model

    n_items, n_colours = problem.n_items, int(start.max()) + 1
    model = cp_model.CpModel()
    x = [[model.new_bool_var(f"x{i}_{c}") for c in range(n_colours)] for i in range(n_items)]
    used = [model.new_bool_var(f"used{c}") for c in range(n_colours)]
    add_colouring(model, cp_model, problem, x, n_colours, used)
    for c in range(n_colours - 1):
        model.add_implication(used[c + 1], used[c])
    for c, item in enumerate(largest_clique(problem).tolist()):
        model.add(x[item][c] == 1)
    model.add(sum(used) >= lower)
    model.minimize(sum(used))
    hint_colours(model, x, start, n_colours)
    solver, status = solve_cp_model(model, time_limit, seed)
    version = f"ortools {distribution_version('ortools')}"
    if status not in (cp_model.OPTIMAL, cp_model.FEASIBLE):
        return start, lower, False, version
    colour = np.array(
        [next(c for c in range(n_colours) if solver.boolean_value(x[i][c])) for i in range(n_items)]
    )
    return (
        _compact(colour),
        int(np.ceil(solver.best_objective_bound - 1e-9)),
        status == cp_model.OPTIMAL,
        version,
    )


def add_colouring(model, cp_model, problem, x, n_colours, used) -> None:
    """Exactly one colour per item; clique rows per colour (linked to ``used`` when given); the cap."""
    for row in x:
        model.add_exactly_one(row)
    in_clique = np.zeros(problem.n_items, dtype=bool)
    for clique in problem.cliques:
        in_clique[clique] = True
        for c in range(n_colours):
            members = [x[i][c] for i in clique.tolist()]
            if used is None:
                model.add_at_most_one(members)
            else:
                model.add(sum(members) <= used[c])
    if used is not None:
        for i in np.flatnonzero(~in_clique).tolist():
            for c in range(n_colours):
                model.add_implication(x[i][c], used[c])
    if problem.cap is not None:
        counts = problem.item_shape_counts.tolist()
        for c in range(n_colours):
            model.add(cp_model.LinearExpr.weighted_sum([row[c] for row in x], counts) <= problem.cap)


def hint_colours(model, x, colour, n_colours) -> None:
    """Hint the CP-SAT ``model`` that item i has colour ``colour[i]`` (its Boolean ``x[i][c]``)."""
    for i, row in enumerate(x):
        for c in range(n_colours):
            model.add_hint(row[c], int(colour[i] == c))


def _compact(colour: np.ndarray) -> np.ndarray:
    """Renumber colours to 0..H-1 in order of first use."""
    _, first = np.unique(colour, return_index=True)
    order = colour[np.sort(first)]
    mapping = np.empty(colour.max() + 1, dtype=np.int64)
    mapping[order] = np.arange(order.size)
    return mapping[colour]


def colour_highs(problem, start, lower, time_limit, seed):
    """The colouring model as a HiGHS MILP: (colours, proved lower bound, proved optimal, version)."""
    import highspy

    from solvers._highs_model import configured_highs, highs_solution, pass_model

    n_items, n_colours = problem.n_items, int(start.max()) + 1
    n_x = n_items * n_colours  # x[i, c] is column i * n_colours + c, used[c] is column n_x + c
    rows, cols, vals, lower_rows, upper_rows = [], [], [], [], []

    def add_row(columns, values, low, high):
        index = len(lower_rows)
        rows.append(np.full(len(columns), index))
        cols.append(np.asarray(columns))
        vals.append(np.asarray(values, dtype=float))
        lower_rows.append(low)
        upper_rows.append(high)

    colours = np.arange(n_colours)
    for i in range(n_items):
        add_row(i * n_colours + colours, np.ones(n_colours), 1.0, 1.0)
    in_clique = np.zeros(n_items, dtype=bool)
    for clique in problem.cliques:
        in_clique[clique] = True
        for c in range(n_colours):
            add_row(
                np.append(clique * n_colours + c, n_x + c),
                np.append(np.ones(clique.size), -1.0),
                -np.inf,
                0.0,
            )
    for i in np.flatnonzero(~in_clique).tolist():
        for c in range(n_colours):
            add_row([i * n_colours + c, n_x + c], [1.0, -1.0], -np.inf, 0.0)
    for c in range(n_colours - 1):
        add_row([n_x + c + 1, n_x + c], [1.0, -1.0], -np.inf, 0.0)
    if problem.cap is not None:
        counts = problem.item_shape_counts.astype(float)
        for c in range(n_colours):
            add_row(
                np.append(np.arange(n_items) * n_colours + c, n_x + c),
                np.append(counts, -problem.cap),
                -np.inf,
                0.0,
            )
    matrix = sp.csr_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
        shape=(len(lower_rows), n_x + n_colours),
    )
    col_lower = np.zeros(n_x + n_colours)
    for c, item in enumerate(largest_clique(problem).tolist()):
        col_lower[item * n_colours + c] = 1.0
    col_lower[n_x : n_x + lower] = 1.0  # used[c] for c < lower bound
    highs = configured_highs(highspy, time_limit, seed)
    pass_model(
        highspy, highs, matrix, np.array(lower_rows), np.array(upper_rows),
        np.concatenate([np.zeros(n_x), np.ones(n_colours)]), col_lower, np.ones(n_x + n_colours),
    )  # fmt: skip
    hint = np.zeros(n_x + n_colours)
    hint[np.arange(n_items) * n_colours + start] = 1.0
    hint[n_x:] = 1.0
    highs.setSolution(highs_solution(highspy, hint))
    highs.run()
    version = f"highspy {highs.version()}"
    info = highs.getInfo()
    if info.primal_solution_status != 2:
        return start, lower, False, version
    values = np.asarray(highs.getSolution().col_value)[:n_x].reshape(n_items, n_colours)
    colour = _compact(np.argmax(values, axis=1))
    bound = int(np.ceil(info.mip_dual_bound - 1e-6)) if np.isfinite(info.mip_dual_bound) else lower
    return colour, bound, highs.getModelStatus() == highspy.HighsModelStatus.kOptimal, version
