"""The base of exact plugins: a plugin solves the presolved `CliqueModel`, this base does the rest.

An exact plugin implements ``solve_model(model, *, time_limit, seed) -> Result`` on the `CliqueModel` (arrays
of eq. 3 after presolve). `ExactSolver.solve` answers the empty problem, applies the exact reductions of
`solvers._reduce` (dominated items out, conflict-free items in: the optimal packings stay exactly the same) so
that the backend sees only the kernel, grows the kernel's rows to maximal cliques of its conflict graph
(`solvers._cliques`: the same feasible packings, a tighter relaxation), leaves out of large kernels the items
that the LP bound proves no optimal packing holds (`solvers._fixing`, reduced-cost fixing: the optimal
packings stay exactly the same), solves a kernel whose conflict graph falls apart component by component
when no cap binds, maps the kernel's items back to the problem's and times the array preparation. A plugin
that declares ``Capabilities(warm_start=True)`` also gets a start packing, ``solve_model(..., start=...)``:
Algorithm 2's packing of the kernel (on a fixed kernel, the best packing
found before, `solvers._fixing`), which its backend takes as an incumbent or hint. When a time limit stops a
backend with no incumbent or one worse than Algorithm 2's packing, the base answers that packing instead
(valid by construction) and says so in ``Result.fallback``, so a time-limited solve always has an incumbent at
least as good as the greedy one. The framework (`solvers.load`) then checks and normalises the answer as for
any plugin.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from packing import Termination, unpack_bit_rows
from solvers._base import Capabilities, Result, Stopwatch, trivial_bound
from solvers._cliques import grown_cliques, kernel_components, kernel_neighbourhoods
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
    (`solvers._cliques.grown_cliques`: the same feasible packings, a tighter relaxation), without the items
    reduced-cost fixing leaves out (`solvers._fixing`; ``solve_model`` may then be called twice, the second
    time on a larger model, when the first fixing's target was not reached). A kernel of at most
    `solvers._enumerate.ENUMERATION_MAX_ITEMS` items is solved by listing its packings, without
    ``solve_model``; without a binding cap, a kernel whose conflict graph falls into several connected
    components is solved component by component. A plugin that must see the problem as given (the paper's
    per-vertex formulation, ``naive-pulp-cbc``) sets ``reduces`` False and overrides `solve_problem`. The
    private switches ``_grows_cliques``, ``_fixes_by_reduced_costs``, ``_enumerates_small_kernels`` and
    ``_decomposes`` turn one reduction off for the project's own comparisons; they are no part of the
    plugin contract.

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
    _grows_cliques: ClassVar[bool] = True
    _fixes_by_reduced_costs: ClassVar[bool] = True
    _enumerates_small_kernels: ClassVar[bool] = True
    _decomposes: ClassVar[bool] = True

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
        Without a binding cap, eq. 3 over a kernel whose conflict graph falls into several connected
        components is the sum of independent problems, one per component (no row holds items of two): each
        is solved on its own (`kernel_components`), a component of at most `ENUMERATION_MAX_ITEMS` items by
        enumeration, and the optimum is the union of theirs, its bound the sum of theirs. Under a binding
        cap the components share the cap row and are solved together. Under a time limit each component in
        turn gets its share of the time left (its share of the items left), so that the backend calls
        together stay within the limit; a component whose turn comes with no time left gets no backend
        call, and each component stopped answers the better of its incumbent and Algorithm 2's packing.

        A ``warm_start`` plugin gets Algorithm 2's packing of the kernel (`start_packing`), or on a fixed
        kernel the best packing found before (why no earlier optimum helps: docs/architecture.md, "What
        makes it fast"). On kernels of `solvers._fixing.FIXING_MIN_ITEMS` items or more, the items whose
        reduced-cost bound falls below a good packing are left out (`solvers._fixing.solve_with_fixing`),
        and so are the kept items that other kept items then dominate.
        """
        clock = Stopwatch()
        if problem.n_items == 0:
            return Result((), Termination.OPTIMAL, 0.0, build_time=0.0, solve_time=0.0)
        cap_binds = problem.cap is not None and problem.cap < int(problem.item_shape_counts.sum())
        searched = [0.0]  # seconds in the backend so far: every backend call of this solve shares the limit
        if not self.reduces:
            model = CliqueModel.from_problem(problem)
            start = start_packing(problem, None) if self.capabilities.warm_start else None
            prepare_time = clock.lap()
            result = self._backend(problem, model, start, time_limit, seed, searched)
            items = _model_items(result.items, model.n_items)
            parts = [_Part(replace(result, items=items), start, 0.0, clock.lap())]
        else:
            reduction = reduce_problem(problem, cap_binds)
            kernels = self._kernels(problem, reduction, cap_binds)
            prepare_time = clock.lap()
            sizes = [kernel.kept.size for kernel, _ in kernels]
            parts = []
            for index, (kernel, closed) in enumerate(kernels):
                # Each component's share of the time left is its share of the items left (what one leaves
                # unused goes to the next); one that starts with no time left gets no backend call.
                budget = None if time_limit is None else time_limit - searched[0]
                if budget is not None and index > 0 and budget <= 0:
                    parts.append(_stopped(problem, kernel))
                    continue
                if budget is not None and len(kernels) > 1:  # (components hold an item each)
                    budget *= sizes[index] / sum(sizes[index:])
                spent = [0.0]
                parts.append(self._solve_kernel(problem, kernel, closed, cap_binds, budget, seed, spent))
                searched[0] += spent[0]
        return _answer(problem, parts, prepare_time)

    def _kernels(
        self, problem: PackingProblem, reduction: Reduction, cap_binds: bool
    ) -> list[tuple[Reduction, np.ndarray]]:
        """The kernel, or its connected components when they are independent problems (no binding cap, the
        first holding the items every optimum takes), each with its closed neighbourhoods as bit rows
        (`kernel_neighbourhoods`)."""
        kept = reduction.kept
        closed = kernel_neighbourhoods(problem.conflict_bits, kept, problem.n_items)
        if not self._decomposes or cap_binds or kept.size <= ENUMERATION_MAX_ITEMS:
            return [(reduction, closed)]
        pieces = kernel_components(closed)
        if len(pieces) == 1:
            return [(reduction, closed)]
        return [
            (
                Reduction(problem, kept[piece], reduction.taken if index == 0 else kept[:0]),
                kernel_neighbourhoods(closed, piece, kept.size),
            )
            for index, piece in enumerate(pieces)
        ]

    def _solve_kernel(
        self,
        problem: PackingProblem,
        kernel: Reduction,
        closed: np.ndarray,
        cap_binds: bool,
        time_limit: float | None,
        seed: int,
        searched: list[float],
    ) -> _Part:
        """The optimum of ``problem`` over the items ``kernel.kept`` (by enumeration when they are few) with
        ``kernel.taken``, as items of ``problem`` (`Reduction.items`); ``closed`` are the closed
        neighbourhoods of ``kernel.kept``."""
        clock = Stopwatch()
        kept = kernel.kept
        if self._enumerates_small_kernels and kept.size <= ENUMERATION_MAX_ITEMS:
            weights = np.asarray(problem.weights, dtype=np.float64)[kept]
            conflicts = unpack_bit_rows(closed, kept.size)
            cap = problem.cap if cap_binds else None
            prepare_time = clock.lap()
            items = kernel.items(enumerated_optimum(weights, problem.item_shape_counts[kept], cap, conflicts))
            message = f"kernel of {kept.size} items solved by enumeration"
            result = Result(items, Termination.OPTIMAL, problem.objective(items), message=message)
            return _Part(result, None, prepare_time, clock.lap())
        model = grown_cliques(kernel.cut_model(), closed) if self._grows_cliques else kernel.model
        start = start_packing(problem, kernel) if self.capabilities.warm_start else None
        costs = None
        if self._fixes_by_reduced_costs:
            costs = reduced_costs(model, () if start is None else start, closed)
        prepare_time = clock.lap()
        if costs is None:
            result = self._backend(problem, model, start, time_limit, seed, searched)
        else:
            warm = start is not None

            def backend(solved: CliqueModel, begin: Sequence[int]) -> Result:
                return self._backend(problem, solved, begin if warm else None, time_limit, seed, searched)

            result = solve_with_fixing(costs, backend)
        items, bound = kernel.items(_model_items(result.items, model.n_items)), result.bound
        if bound is not None:
            bound += float(problem.weights[kernel.taken].sum())
        if start is None and result.termination is Termination.TIME_LIMIT:
            start = start_packing(problem, kernel)  # (the fallback, for a plugin that takes no start)
        begun = None if start is None else kernel.items(start)
        solve_time = clock.lap()
        return _Part(replace(result, items=items, bound=bound), begun, prepare_time, solve_time)

    def _backend(
        self,
        problem: PackingProblem,
        model: CliqueModel,
        start: Sequence[int] | None,
        time_limit: float | None,
        seed: int,
        searched: list[float],
    ) -> Result:
        """`solve_problem` on ``model`` with what is left of the time limit after ``searched[0]`` seconds
        (at least `LEAST_SEARCH_SECONDS`), adding its seconds to ``searched[0]``."""
        if model.n_items == 0:  # the reductions decided every item
            return Result((), Termination.OPTIMAL, 0.0, build_time=0.0, solve_time=0.0)
        hint = {} if start is None else {"start": start}  # `solve_problem` overrides may not take one
        left = None if time_limit is None else max(time_limit - searched[0], LEAST_SEARCH_SECONDS)
        call = Stopwatch()
        answer = self.solve_problem(problem, model, time_limit=left, seed=seed, **hint)
        searched[0] += call.lap()
        return answer


def _stopped(problem: PackingProblem, kernel: Reduction) -> _Part:
    """The part of a kernel whose turn came after the time limit: no backend run, Algorithm 2's packing
    of its items as the start (`start_packing`) and the sum of their positive weights as the bound."""
    clock = Stopwatch()
    start = kernel.items(start_packing(problem, kernel))
    bound = trivial_bound(problem, np.concatenate([kernel.taken, kernel.kept]))
    message = "no time left for this component"
    result = Result((), Termination.TIME_LIMIT, bound, message=message)
    return _Part(result, start, clock.lap(), 0.0)


@dataclass(frozen=True)
class _Part:
    """The answer for one kernel (or one component of it) with the items it takes: ``result.items`` and
    ``start`` are items of the problem, ``result.bound`` bounds this part alone; ``prepare_time`` is the
    seconds before its backend ran, ``seconds`` those after."""

    result: Result
    start: tuple[int, ...] | None
    prepare_time: float
    seconds: float


def _answer(problem: PackingProblem, parts: Sequence[_Part], prepare_time: float) -> Result:
    """The problem's answer from its parts' and the seconds spent before them (the reductions): the union
    of their items, the sum of their bounds, OPTIMAL when every part is; at a time limit the better of that
    packing and Algorithm 2's (`ExactSolver.solve`)."""
    results = [part.result for part in parts]
    build_time = prepare_time + sum(part.prepare_time + (part.result.build_time or 0.0) for part in parts)
    solve_time = sum(
        part.seconds if part.result.solve_time is None else part.result.solve_time for part in parts
    )
    version = next((r.version for r in results if r.version), "")
    failed = [r for r in results if r.termination not in (Termination.OPTIMAL, Termination.TIME_LIMIT)]
    if failed:
        return replace(failed[0], items=(), bound=None, build_time=build_time, solve_time=solve_time)
    items = tuple(sorted(i for r in results for i in r.items))
    bounds = [r.bound for r in results]
    bound = None if None in bounds else float(sum(bounds))
    if bound is not None and all(r.termination is Termination.OPTIMAL for r in results):
        bound = max(bound, problem.objective(items))  # (the parts' sums may round a unit below the whole's)
    messages = [r.message for r in results if r.message]
    if len(parts) > 1:
        sizes = ", ".join(str(len(part.result.items)) for part in parts)
        messages.insert(0, f"kernel solved as {len(parts)} components (items chosen: {sizes})")
    message = "; ".join(dict.fromkeys(messages))
    fallback = next((r.fallback for r in results if r.fallback), "")
    timed_out = any(r.termination is Termination.TIME_LIMIT for r in results)
    if timed_out:
        from solvers.greedy import greedy_items

        # Each part's better packing of its incumbent and its start: the parts share no row (and no cap).
        started = tuple(
            i for part in parts for i in max((part.result.items, part.start or ()), key=problem.objective)
        )
        candidates = [tuple(sorted(greedy_items(problem))), tuple(sorted(started))]  # one sum order each
        greedy = max(candidates, key=problem.objective)
        if not items or problem.objective(greedy) > problem.objective(items):
            items, fallback = greedy, "greedy"
            message = (
                message + "; " if message else ""
            ) + "incumbent at the time limit: Algorithm 2's packing"
        if bound is None or bound < problem.objective(items) - 1e-9 * max(1.0, abs(bound)):
            bound = trivial_bound(problem)  # the backends proved nothing usable before they stopped
    termination = Termination.TIME_LIMIT if timed_out else Termination.OPTIMAL
    return Result(items, termination, bound, build_time, solve_time, version, message, fallback)


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


def _model_items(items: Iterable[int], n_items: int) -> tuple[int, ...]:
    """The backend's items as Python ints, ascending (one summation order of eq. 3a per packing), each an
    item of the model it solved, none twice."""
    chosen = [int(i) for i in items]
    if any(not 0 <= i < n_items for i in chosen) or len(set(chosen)) != len(chosen):
        raise ValueError(f"the backend answered items {chosen} for a model of {n_items} items")
    return tuple(sorted(chosen))
