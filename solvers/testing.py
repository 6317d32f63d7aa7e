"""Conformance checks for solver plugins (as scikit-learn's ``check_estimator``), usable by third parties.

>>> from solvers.testing import check_solver
>>> from solvers.greedy import GreedySolver
>>> check_solver(GreedySolver)  # raises AssertionError naming the failed check
['declaration', 'answer', 'validity', 'objective', 'maximality', 'determinism', 'time limit']

Every check runs the solver, behind the framework's normalisation (`solvers.load`), on small generated
problems (random sparse active-vertex sets, symmetry pairs, caps, apart pairs) and verifies its answers
independently of the presolve (`CHECKS`): the declaration; the answer's type and the normalised `Solution`'s
fields; items valid and pairwise disjoint on the incidence matrix (or within the declared ``max_overlap``),
the cap and apart pairs respected; the brute-force optimum for exact solvers, no better than it for strict
heuristics; maximality (no item of positive weight still fits: a do-nothing heuristic fails); determinism
where claimed; a usable answer under a tiny time limit where claimed. `check_solver` runs them all and
stops at the first failure; `parametrize_with_checks` makes one pytest case per check.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable, Iterable, Iterator
from typing import Any

import numpy as np

from packing import PackingProblem, Solution, Termination, problem_from_incidence
from registry import parametrize_checks, run_checks
from solvers._base import Availability, Capabilities, Result
from solvers._exact import ExactSolver
from solvers._loaded import LoadedSolver, load
from solvers._problems import face_like_problem, random_problem

__all__ = [
    "CHECKS",
    "brute_force_optimum",
    "check_answer",
    "check_declaration",
    "check_determinism",
    "check_maximality",
    "check_objective",
    "check_packing",
    "check_solver",
    "check_time_limit",
    "check_validity",
    "parametrize_with_checks",
    "conformance_problems",
    "face_like_problem",
    "hard_problem",
    "random_problem",
]

#: Relative tolerance of objective comparisons (eq. 3a values are summed in double precision).
OBJECTIVE_TOLERANCE = 1e-9


def check_packing(problem: PackingProblem, items: Iterable[int], *, overlap: float = 0.0) -> None:
    """Assert that ``items`` is a valid expression of ``problem``, from the incidence matrix alone.

    Parameters
    ----------
    problem : PackingProblem
    items : iterable of int
    overlap : float in [0, 1)
        Allowed overlap fraction (sec. 4.5.2). 0 demands pairwise disjoint active vertices (eq. 3b).
        Otherwise the items must admit an order in which each one overlaps the union of the earlier ones
        in at most ``overlap * |b_k|`` vertices (the rule of ``greedy-overlap``); this is checked by
        peeling off, last first, any item that satisfies it against all the others.

    Raises
    ------
    AssertionError
        Naming the offending items.
    """
    chosen = [int(i) for i in items]
    assert all(0 <= i < problem.n_items for i in chosen), (
        f"item index out of range 0..{problem.n_items - 1}: {chosen}"
    )
    assert len(set(chosen)) == len(chosen), f"an item is chosen twice: {chosen}"
    if problem.cap is not None:
        shapes = int(problem.item_shape_counts[chosen].sum())
        assert shapes <= problem.cap, f"{shapes} blendshapes chosen, cap is {problem.cap}"
    together = set(chosen)
    for a, b in problem.apart:
        assert not (a in together and b in together), f"items {a} and {b} are apart but both chosen"
    rows = problem.incidence[chosen].astype(np.int64)
    if overlap == 0.0:
        per_vertex = np.asarray(rows.sum(axis=0)).ravel()
        if per_vertex.size and per_vertex.max(initial=0) > 1:
            vertex = int(np.argmax(per_vertex))
            sharing = [chosen[r] for r in rows[:, vertex].nonzero()[0]]
            raise AssertionError(f"items {sharing} share vertex {vertex} (eq. 3b)")
        return
    dense = rows.toarray().astype(bool)
    sizes = dense.sum(axis=1)
    remaining = list(range(len(chosen)))
    while remaining:

        def overlap_with_others(r: int) -> int:
            others = dense[[o for o in remaining if o != r]].any(axis=0)
            return int(np.count_nonzero(dense[r] & others))

        last = next((r for r in remaining if overlap_with_others(r) <= overlap * sizes[r] + 1e-9), None)
        assert last is not None, f"items {[chosen[r] for r in remaining]} overlap by more than {overlap:g}"
        remaining.remove(last)


def brute_force_optimum(problem: PackingProblem) -> tuple[float, tuple[int, ...]]:
    """Best objective and items over all subsets (problems of up to 20 items), from the incidence matrix
    and the apart pairs; the objective includes the tie-break, as the backends maximise it.

    Ties are broken towards the lexicographically smallest bitmask; only the objective is compared.
    """
    n = problem.n_items
    if n > 20:
        raise ValueError(f"brute_force_optimum enumerates 2**n subsets; {n} items is too many")
    if n == 0:
        return 0.0, ()
    rows = problem.incidence.astype(np.int64)
    overlaps = (rows @ rows.T).toarray() > 0
    masks = np.arange(2**n, dtype=np.int64)
    bits = ((masks[:, None] >> np.arange(n)) & 1).astype(bool)
    conflict_bits = np.array([sum(1 << j for j in range(n) if overlaps[i, j] and j != i) for i in range(n)])
    valid = np.ones(masks.size, dtype=bool)
    for a, b in problem.apart:
        conflict_bits[a] |= 1 << b
        conflict_bits[b] |= 1 << a
    for i in range(n):
        valid &= ~(bits[:, i] & ((masks & conflict_bits[i]) != 0))
    if problem.cap is not None:
        valid &= bits @ problem.item_shape_counts <= problem.cap
    values = np.where(valid, bits @ problem.weights, -np.inf)
    best = int(np.argmax(values))
    return float(values[best]), tuple(np.flatnonzero(bits[best]).tolist())


def conformance_problems(seed: int = 0) -> list[tuple[str, PackingProblem]]:
    """Small named problems that exercise pairs, caps and degenerate cases (all <= 14 items)."""
    rng = np.random.default_rng(seed)
    problems = [
        (f"random-{k}", random_problem(int(rng.integers(8, 15)), 30, seed=seed * 100 + k, active=(2, 7)))
        for k in range(4)
    ]
    problems += [
        (f"capped-{k}", random_problem(12, 40, seed=seed * 100 + 10 + k, active=(1, 6), cap=3 + k))
        for k in range(2)
    ]
    problems += [
        ("empty", problem_from_incidence(np.zeros((0, 5), dtype=bool), np.zeros(0))),
        ("single", problem_from_incidence(np.ones((1, 3), dtype=bool), [0.7])),
        ("disjoint", problem_from_incidence(np.eye(6, dtype=bool), np.linspace(0.1, 0.6, 6))),
        ("one-clique", problem_from_incidence(np.ones((5, 4), dtype=bool), [0.2, 0.9, 0.4, 0.3, 0.1])),
        ("pairs-with-cap-1", random_problem(8, 20, seed=seed + 7, pairs=0.5, cap=1)),
        (
            "apart",
            problem_from_incidence(np.eye(6, dtype=bool), np.linspace(0.1, 0.6, 6), apart=[(0, 1), (2, 5)]),
        ),
    ]
    return problems


def hard_problem(seed: int = 0) -> PackingProblem:
    """Many items with heavily overlapping random vertex sets: no backend proves it in 0.05 s."""
    return random_problem(300, 400, seed=seed, active=(6, 12), pairs=0.2)


def _loaded(solver: Any) -> LoadedSolver:
    """The solver behind the framework's normalisation; a RuntimeError when it cannot run here.

    An exact plugin (`solvers.ExactSolver`) is checked on a copy that sends every kernel to its backend:
    the conformance problems are small enough for the base to solve them all by enumeration otherwise."""
    loaded = load(solver)
    if isinstance(loaded.plugin, ExactSolver) and loaded.plugin._enumerates_small_kernels:
        backend_only = copy.copy(loaded.plugin)
        backend_only._enumerates_small_kernels = False
        loaded = load(backend_only)
    found = loaded.availability()
    if not found:
        raise RuntimeError(f"{loaded.name} is unavailable here, cannot check it: {found.reason}")
    return loaded


def _solutions(loaded: LoadedSolver, seed: int) -> Iterator[tuple[str, PackingProblem, Solution]]:
    """The solver's normalised answer to every conformance problem it declares it can take."""
    for label, problem in conformance_problems(seed):
        if problem.cap is not None and not loaded.capabilities.supports_cap:
            continue
        yield f"{loaded.name} on {label!r}", problem, loaded.solve(problem, seed=seed)


def check_declaration(solver: Any, seed: int = 0) -> None:
    """``name`` is a non-empty str, ``capabilities`` a `Capabilities`, ``availability()`` an
    `Availability` that says why when it is falsy."""
    plugin = load(solver).plugin
    name = getattr(plugin, "name", None)
    kind = type(plugin).__name__
    assert isinstance(name, str) and name, f"{kind}.name must be a non-empty str, got {name!r}"
    assert isinstance(getattr(plugin, "capabilities", None), Capabilities), (
        f"{name}.capabilities must be a solvers.Capabilities"
    )
    found = plugin.availability()
    assert isinstance(found, Availability), f"{name}.availability() must return a solvers.Availability"
    assert bool(found) or found.reason, f"{name}: an unavailable solver must say why"


def check_answer(solver: Any, seed: int = 0) -> None:
    """``solve`` returns a `Result` (the one answer a plugin gives) whose items are the problem's, none
    twice, and whose termination is a `Termination`; the framework turns it into a consistent `Solution`."""
    loaded = _loaded(solver)
    problem = random_problem(10, 30, seed=seed, active=(2, 6))
    raw = loaded.plugin.solve(problem, time_limit=None, seed=seed)
    assert isinstance(raw, Result), (
        f"{loaded.name}: solve returned {type(raw).__name__}, not a solvers.Result"
    )
    for where, problem, solution in _solutions(loaded, seed):
        _check_fields(problem, solution, loaded.name, where)


def check_validity(solver: Any, seed: int = 0) -> None:
    """Every expression is valid on the incidence matrix alone (eq. 3b, or within the declared
    ``max_overlap``), respects the cap and the apart pairs."""
    loaded = _loaded(solver)
    for where, problem, solution in _solutions(loaded, seed):
        try:
            check_packing(problem, solution.items, overlap=loaded.capabilities.max_overlap)
        except AssertionError as error:
            raise AssertionError(f"{where}: invalid expression: {error}") from None


def check_objective(solver: Any, seed: int = 0) -> None:
    """An exact solver ends OPTIMAL at the brute-force optimum; a heuristic ends COMPLETED (or OPTIMAL) no
    better than it (strict solvers: eq. 3 has no better packing)."""
    loaded = _loaded(solver)
    capabilities = loaded.capabilities
    for where, problem, solution in _solutions(loaded, seed):
        best, _ = brute_force_optimum(problem)
        tolerance = OBJECTIVE_TOLERANCE * max(1.0, abs(best))
        found = problem.objective(solution.items)  # with the tie-break, as the backends maximise it
        assert found <= best + tolerance or not capabilities.strict, (
            f"{where}: objective {found!r} exceeds the brute-force optimum {best!r}"
        )
        if capabilities.exact:
            assert solution.termination is Termination.OPTIMAL, (
                f"{where}: exact solver ended {solution.termination}"
            )
            assert abs(found - best) <= tolerance, (
                f"{where}: objective {found!r} differs from the brute-force optimum {best!r}"
            )
        else:
            assert solution.termination in (Termination.COMPLETED, Termination.OPTIMAL), (
                f"{where}: heuristic ended {solution.termination}"
            )


def check_maximality(solver: Any, seed: int = 0) -> None:
    """A solver that ran to its end leaves no item of positive weight that still fits the expression
    (no shared vertex beyond the declared overlap, room under the cap, no apart partner chosen): a
    packing that could take one more item for free is never the answer of Algorithm 2 or eq. 3."""
    loaded = _loaded(solver)
    overlap = loaded.capabilities.max_overlap
    for where, problem, solution in _solutions(loaded, seed):
        if solution.termination not in (Termination.OPTIMAL, Termination.COMPLETED):
            continue
        fitting = [
            item
            for item in range(problem.n_items)
            if item not in solution.items
            and problem.weights[item] > 0
            and _fits(problem, solution.items, item, overlap)
        ]
        assert not fitting, f"{where}: items {fitting} still fit the expression {solution.items}"


def check_determinism(solver: Any, seed: int = 0) -> None:
    """A solver that declares ``deterministic`` gives the same items for the same problem and seed."""
    loaded = _loaded(solver)
    if not loaded.capabilities.deterministic:
        return
    for where, problem, solution in _solutions(loaded, seed):
        again = loaded.solve(problem, seed=seed)
        assert again.items == solution.items, (
            f"{where}: not deterministic: {solution.items} then {again.items}"
        )


def check_time_limit(solver: Any, seed: int = 0) -> None:
    """A solver that declares ``time_limit`` stops on a hard problem with a valid incumbent and a bound."""
    loaded = _loaded(solver)
    if not loaded.capabilities.time_limit:
        return
    problem = hard_problem(seed)
    solution = loaded.solve(problem, time_limit=0.05, seed=seed)
    where = f"{loaded.name} on the hard problem with time_limit=0.05"
    _check_fields(problem, solution, loaded.name, where)
    assert solution.termination in (Termination.OPTIMAL, Termination.TIME_LIMIT), (
        f"{where}: ended {solution.termination}"
    )
    assert solution.items, f"{where}: no incumbent"
    check_packing(problem, solution.items)
    assert solution.bound is not None and solution.bound >= solution.objective, (
        f"{where}: bound {solution.bound}"
    )


#: Every conformance check, in the order `check_solver` runs them.
CHECKS: dict[str, Callable[..., None]] = {
    "declaration": check_declaration,
    "answer": check_answer,
    "validity": check_validity,
    "objective": check_objective,
    "maximality": check_maximality,
    "determinism": check_determinism,
    "time limit": check_time_limit,
}


def parametrize_with_checks(solvers: Iterable[Any]):
    """A ``pytest.mark.parametrize`` over every (solver, check) pair, as scikit-learn's.

    Examples
    --------
    ::

        from solvers.testing import parametrize_with_checks

        @parametrize_with_checks([MySolver])
        def test_my_solver(solver, check):
            check(solver)
    """
    return parametrize_checks(CHECKS, solvers, "solver", lambda solver: load(solver).name)


def check_solver(solver: Any, *, seed: int = 0) -> list[str]:
    """Run every conformance check on a solver plugin (class, instance or `solvers.get` result).

    Parameters
    ----------
    solver : Solver class or instance, or LoadedSolver
        A class is instantiated without arguments.
    seed : int
        Seed of the generated problems.

    Returns
    -------
    list of str: the names of the checks that ran (`CHECKS`).

    Raises
    ------
    AssertionError
        On the first failed check, naming the check and the problem.
    RuntimeError
        When the solver reports itself unavailable here (the reason is in the message).
    """
    return run_checks(CHECKS, solver, seed)


def _fits(problem: PackingProblem, chosen: tuple[int, ...], item: int, overlap: float) -> bool:
    """Whether ``item`` can join ``chosen``: the cap, the apart pairs and the vertex overlap allow it."""
    if problem.cap is not None and problem.item_shape_counts[[*chosen, item]].sum() > problem.cap:
        return False
    if any({item, other} == {a, b} for a, b in problem.apart for other in chosen):
        return False
    taken = np.asarray(problem.incidence[list(chosen)].sum(axis=0)).ravel() > 0
    own = problem.incidence[item].indices
    return np.count_nonzero(taken[own]) <= overlap * own.size + 1e-9


def _check_fields(problem: PackingProblem, solution: Solution, name: str, where: str) -> None:
    assert isinstance(solution, Solution), (
        f"{where}: solve returned {type(solution).__name__}, not a Solution"
    )
    assert isinstance(solution.termination, Termination), f"{where}: termination is not a packing.Termination"
    assert solution.termination is not Termination.ERROR, f"{where}: error: {solution.message}"
    assert solution.items == tuple(sorted(set(solution.items))), (
        f"{where}: items not ascending: {solution.items}"
    )
    assert all(isinstance(i, int) for i in solution.items), f"{where}: items must be Python ints"
    assert solution.shapes == problem.shapes_of(solution.items), f"{where}: shapes do not match the items"
    expected = problem.unperturbed_objective(solution.items)
    assert math.isclose(solution.objective, expected, rel_tol=OBJECTIVE_TOLERANCE, abs_tol=1e-12), (
        f"{where}: objective {solution.objective!r} is not the items' importance sum {expected!r} (eq. 3a)"
    )
    if solution.bound is not None:
        assert solution.bound >= solution.objective - OBJECTIVE_TOLERANCE * max(1.0, abs(expected)), (
            f"{where}: bound {solution.bound!r} below the objective {solution.objective!r}"
        )
    for field in ("build_time", "solve_time"):
        value = getattr(solution, field)
        assert isinstance(value, float) and value >= 0.0 and math.isfinite(value), (
            f"{where}: {field} = {value!r}"
        )
    assert solution.backend == name, f"{where}: backend {solution.backend!r}, expected {name!r}"
    assert isinstance(solution.version, str) and solution.version, f"{where}: version must be a non-empty str"
