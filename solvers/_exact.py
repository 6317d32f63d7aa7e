"""The base of exact plugins: a plugin solves the presolved `CliqueModel`, this base does the rest.

An exact plugin implements ``solve_model(model, *, time_limit, seed) -> Result`` on the `CliqueModel` (arrays
of eq. 3 after presolve). `ExactSolver.solve` answers the empty problem, applies the exact reductions of
`solvers._reduce` (dominated items out, conflict-free items in: the optimal packings stay exactly the same) so
that the backend sees only the kernel, grows the kernel's rows to maximal cliques of its conflict graph
(`solvers._cliques`: the same feasible packings, a tighter relaxation), leaves out of large kernels the items
that the LP bound proves no optimal packing holds (`solvers._fixing`, reduced-cost fixing: the optimal
packings stay exactly the same), maps the kernel's items back to the problem's and times the array
preparation. A plugin that declares ``Capabilities(warm_start=True)`` also gets a start packing,
``solve_model(..., start=...)``: Algorithm 2's packing of the kernel (on a fixed kernel, the best packing
found before, `solvers._fixing`), which its backend takes as an incumbent or hint. When a time limit stops a
backend with no incumbent or one worse than Algorithm 2's packing, the base answers that packing instead
(valid by construction) and says so in ``Result.fallback``, so a time-limited solve always has an incumbent at
least as good as the greedy one. The framework (`solvers.load`) then checks and normalises the answer as for
any plugin.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from packing import Termination, unpack_bit_rows
from solvers._base import Capabilities, Result, Stopwatch, trivial_bound
from solvers._cliques import grown_cliques, kernel_neighbourhoods
from solvers._enumerate import ENUMERATION_MAX_ITEMS, enumerated_optimum
from solvers._fixing import reduced_costs, solve_with_fixing
from solvers._model import CliqueModel
from solvers._reduce import Reduction, reduce_problem

if TYPE_CHECKING:
    from packing import PackingProblem


#: Seconds a backend call still gets when reduced-cost fixing's earlier calls used up the time limit (the
#: start packing is its incumbent).
LEAST_SEARCH_SECONDS = 0.01


class ExactSolver:
    """A `Solver` whose subclasses solve eq. 3 on the presolved model (MILP, CP-SAT, ...).

    Subclasses set ``name``, ``capabilities`` and ``availability`` as any plugin, and implement
    `solve_model`. ``reduces`` (default True) applies `solvers._reduce.reduce_problem` first, so
    ``solve_model`` gets the model of the kernel, its rows grown to maximal cliques of the conflict graph
    when ``grows_cliques`` (default True, `solvers._cliques.grown_cliques`: the same feasible packings, a
    tighter relaxation; False solves the kernel's conflict sets as they are, for comparisons), and
    without the items reduced-cost fixing leaves out when ``fixes_by_reduced_costs`` (default True,
    `solvers._fixing`; ``solve_model`` may then be called twice, the second time on a larger model, when
    the first fixing's target was not reached; False solves the whole kernel, for comparisons). A kernel
    of at most `solvers._enumerate.ENUMERATION_MAX_ITEMS` items is solved by listing its packings, without
    ``solve_model``, when ``enumerates_small_kernels`` (default True; False sends it to the backend, for
    comparisons). A plugin that must see the problem as given (the paper's per-vertex formulation,
    ``naive-pulp-cbc``) sets ``reduces`` False and overrides `solve_problem`.

    A subclass that declares ``Capabilities(warm_start=True)`` accepts ``start`` in ``solve_model``.
    The start is opted into by that typed flag rather than detected from the signature: it is declared
    where every other ability is (``harness list`` shows it), a wrapped or ``**kwargs`` ``solve_model``
    cannot be misread, and a plugin written before the start existed keeps its signature and works
    unchanged. Declaring the flag False on a subclass solves without the start (for comparisons).

    Examples
    --------
    ``examples/solver_plugin/example_scipy_milp.py`` is a complete plugin on SciPy's MILP interface:
    ``solve_model`` calls ``scipy.optimize.milp(-model.weights, integrality=1, bounds=(0, 1),
    constraints=model.constraint())`` and returns ``Result(items, termination, bound=...)``.
    """

    name: ClassVar[str]
    capabilities: ClassVar[Capabilities]
    reduces: ClassVar[bool] = True
    grows_cliques: ClassVar[bool] = True
    fixes_by_reduced_costs: ClassVar[bool] = True
    enumerates_small_kernels: ClassVar[bool] = True

    def solve_model(
        self, model: CliqueModel, *, time_limit: float | None, seed: int, start: Sequence[int] = ()
    ) -> Result:
        """Solve ``max w.x`` over the model's clique rows and cap row, x binary (eq. 3 after presolve).

        Parameters
        ----------
        model : CliqueModel
        time_limit : float or None
            Seconds for the backend's search.
        seed : int
            The backend's random seed.
        start : sequence of int
            A feasible packing of ``model`` (indices of its items, possibly empty) to start the search
            from; passed only when the plugin declares ``Capabilities(warm_start=True)``.

        Returns
        -------
        Result
            Items as indices of ``model``; OPTIMAL (MIP gap 0) or TIME_LIMIT with the incumbent and the
            proved bound, or ERROR with the backend's message.
        """
        raise NotImplementedError(f"{type(self).__name__} must implement solve_model")

    def solve_problem(
        self,
        problem: PackingProblem,
        model: CliqueModel,
        *,
        time_limit: float | None,
        seed: int,
        start: Sequence[int] | None = None,
    ) -> Result:
        """The backend's answer for ``problem``, presolved as ``model`` (by default `solve_model`'s), with
        the start packing of ``model``'s items when the plugin declares ``warm_start`` (else None)."""
        if start is None:
            return self.solve_model(model, time_limit=time_limit, seed=seed)
        return self.solve_model(model, time_limit=time_limit, seed=seed, start=start)

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Result:
        """Solve eq. 3 to proven optimality (MIP gap 0) or until ``time_limit`` (build time not included).

        Returns
        -------
        Result
            Items of ``problem``; at a time limit the better of the backend's incumbent and Algorithm 2's
            packing (``fallback="greedy"`` when that packing is the answer), with a bound no lower than it.

        Notes
        -----
        A ``warm_start`` plugin gets Algorithm 2's packing of the kernel (`start_packing`), or on a fixed
        kernel the best packing found before. Algorithm 1 removes every chosen item before the next
        expression, so the previous expression's optimum has nothing left to offer as a start. Nor does any
        other piece of an optimum carry over: without a cap every connected component of the conflict graph
        holding an item of positive weight gives the optimum at least one item, so no component survives an
        expression untouched (and under a cap the components are not independent at all); the kernels of the
        60 largest problems of a 2,000-shape film sequence are one component each. The previous optimum bounds
        the next one from above only (when ``beta = 0`` keeps the weights), while a cut-off prunes from below,
        as the start's objective already does. What speeds the proofs up is the tighter relaxation of the
        grown clique rows, and what that relaxation proves before the backend starts: on kernels of
        `solvers._fixing.FIXING_MIN_ITEMS` items or more, the items whose reduced-cost bound falls below a
        good packing are left out (`solvers._fixing.solve_with_fixing`), which halves the models of the
        largest problems, and so are the kept items that other kept items then dominate.
        """
        clock = Stopwatch()
        if problem.n_items == 0:
            return Result((), Termination.OPTIMAL, 0.0, build_time=0.0, solve_time=0.0)
        cap_binds = problem.cap is not None and problem.cap < int(problem.item_shape_counts.sum())
        reduction = reduce_problem(problem, cap_binds) if self.reduces else None
        if reduction is not None and self.enumerates_small_kernels:
            if reduction.kept.size <= ENUMERATION_MAX_ITEMS:
                return _enumerated(problem, reduction, cap_binds, clock)
        closed = None  # the kernel's closed neighbourhoods as bit rows, when the clique growing has them
        if reduction is None:
            model = CliqueModel.from_problem(problem)
        elif self.grows_cliques:
            closed = kernel_neighbourhoods(problem.conflict_bits, reduction.kept, problem.n_items)
            model = grown_cliques(reduction.cut_model(), closed)
        else:
            model = reduction.model
        start = start_packing(problem, reduction) if self.capabilities.warm_start else None
        costs = None
        if reduction is not None and self.fixes_by_reduced_costs:
            costs = reduced_costs(model, () if start is None else start, closed)
        prepare_time = clock.lap()

        searched = [0.0]  # seconds in the backend so far: the calls of reduced-cost fixing share the limit

        def backend(solved: CliqueModel, begin: Sequence[int] | None) -> Result:
            if solved.n_items == 0:  # the reductions decided every item
                return Result((), Termination.OPTIMAL, 0.0, build_time=0.0, solve_time=0.0)
            hint = {} if begin is None else {"start": begin}  # `solve_problem` overrides may not take one
            left = None if time_limit is None else max(time_limit - searched[0], LEAST_SEARCH_SECONDS)
            call = Stopwatch()
            answer = self.solve_problem(problem, solved, time_limit=left, seed=seed, **hint)
            searched[0] += call.lap()
            return answer

        if costs is None:
            result = backend(model, start)
        else:
            warm = start is not None
            result = solve_with_fixing(costs, lambda solved, begin: backend(solved, begin if warm else None))
        items, message, bound = _model_items(result.items, model.n_items), result.message, result.bound
        if reduction is not None:
            items = reduction.items(items)
            if bound is not None:
                bound += float(problem.weights[reduction.taken].sum())
        fallback = result.fallback
        if result.termination is Termination.TIME_LIMIT:
            from solvers.greedy import greedy_items

            candidates = [tuple(sorted(greedy_items(problem)))]  # sorted: one sum order per packing
            if start is not None:
                candidates.append(start if reduction is None else reduction.items(start))
            greedy = max(candidates, key=problem.objective)
            if not items or problem.objective(greedy) > problem.objective(items):
                items, fallback = greedy, "greedy"
                message = (
                    message + "; " if message else ""
                ) + "incumbent at the time limit: Algorithm 2's packing"
            if bound is None or bound < problem.objective(items) - 1e-9 * max(1.0, abs(bound)):
                bound = trivial_bound(problem)  # the backend proved nothing usable before it stopped
        return replace(
            result,
            items=items,
            bound=bound,
            message=message,
            fallback=fallback,
            build_time=prepare_time + (result.build_time or 0.0),
            solve_time=result.solve_time if result.solve_time is not None else clock.lap(),
        )


def start_packing(problem: PackingProblem, reduction: Reduction | None) -> tuple[int, ...]:
    """A start for eq. 3 from Algorithm 2 (sec. 4.5.2), as indices of the kernel's model.

    Two greedy packings of the kernel and the items every optimum takes (`Reduction.taken`), the better
    by eq. 3a: Algorithm 2 visiting only those items in `solvers.greedy.greedy_order` (no dominated item
    blocks a better one), and Algorithm 2's packing of the whole problem without its dominated items,
    completed greedily in the same order. With no reduction it is Algorithm 2's packing of the problem.

    Parameters
    ----------
    problem : PackingProblem
    reduction : Reduction or None
        The exact reductions applied before the backend, if any.

    Returns
    -------
    tuple of int, ascending: items of ``reduction.model`` (of ``problem`` when ``reduction`` is None).

    Notes
    -----
    O(I log I) for the order plus three runs of Algorithm 2 on the presolved conflict sets, one when
    Algorithm 2's packing of the whole problem holds only items the reductions left (the two visits of the
    kernel then choose that packing again).
    """
    from solvers.greedy import greedy_items, greedy_order

    if reduction is None:
        return tuple(sorted(greedy_items(problem)))
    order = greedy_order(problem)
    live = np.zeros(problem.n_items, dtype=bool)
    live[reduction.kept] = True
    live[reduction.taken] = True
    whole = np.asarray(greedy_items(problem, order=order), dtype=np.int64)
    if live[whole].all():
        # Both visits below choose exactly ``whole``: the items it passed over were blocked by, or had no room
        # left beside, items of ``whole`` visited earlier (all of them first in the second visit).
        best = whole
    else:
        kept_whole = np.zeros(problem.n_items, dtype=bool)
        kept_whole[whole[live[whole]]] = True
        orders = (
            order[live[order]],
            np.concatenate([order[kept_whole[order]], order[live[order] & ~kept_whole[order]]]),
        )
        best = max((greedy_items(problem, order=visit) for visit in orders), key=problem.objective)
    chosen = np.sort(np.asarray(best, dtype=np.int64))
    return tuple(np.searchsorted(reduction.kept, chosen[np.isin(chosen, reduction.kept)]).tolist())


def _enumerated(problem: PackingProblem, reduction: Reduction, cap_binds: bool, clock: Stopwatch) -> Result:
    """The optimum of a problem whose kernel holds at most `ENUMERATION_MAX_ITEMS` items, by listing the
    kernel's packings (`solvers._enumerate`): proved optimal, no backend run."""
    kept = reduction.kept
    closed = kernel_neighbourhoods(problem.conflict_bits, kept, problem.n_items)
    conflicts = unpack_bit_rows(closed, kept.size)
    weights = np.asarray(problem.weights, dtype=np.float64)[kept]
    cap = problem.cap if cap_binds else None
    build_time = clock.lap()
    items = reduction.items(enumerated_optimum(weights, problem.item_shape_counts[kept], cap, conflicts))
    message = f"kernel of {kept.size} items solved by enumeration"
    objective = problem.objective(items)
    return Result(items, Termination.OPTIMAL, objective, build_time, clock.lap(), message=message)


def _model_items(items: Iterable[int], n_items: int) -> tuple[int, ...]:
    """The backend's items as Python ints, ascending (one summation order of eq. 3a per packing), each an
    item of the model it solved, none twice."""
    chosen = [int(i) for i in items]
    if any(not 0 <= i < n_items for i in chosen) or len(set(chosen)) != len(chosen):
        raise ValueError(f"the backend answered items {chosen} for a model of {n_items} items")
    return tuple(sorted(chosen))
