"""Conformance checks for solver plugins (as scikit-learn's ``check_estimator``), usable by third parties.

>>> from solvers.testing import check_solver
>>> from solvers.greedy import GreedySolver
>>> check_solver(GreedySolver)  # raises AssertionError naming the failed check

Every check runs the solver on small generated problems (random sparse active-vertex sets, symmetry
pairs, caps) and verifies its answers independently of the presolve: items valid and pairwise disjoint
on the incidence matrix (or within the allowed overlap for non-strict solvers), the cap respected,
the `Solution` fields consistent, determinism where claimed, the brute-force optimum for exact solvers,
and a usable answer under a tiny time limit.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

from packing import PackingProblem, Solution, Termination, problem_from_incidence
from solvers._base import Availability, Capabilities, Solver
from solvers._problems import face_like_problem, random_problem

__all__ = [
    "brute_force_optimum",
    "check_packing",
    "check_solver",
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
    ]
    return problems


def hard_problem(seed: int = 0) -> PackingProblem:
    """Many items with heavily overlapping random vertex sets: no backend proves it in 0.05 s."""
    return random_problem(300, 400, seed=seed, active=(6, 12), pairs=0.2)


def _instance(solver) -> Solver:
    return solver() if isinstance(solver, type) else solver


def check_solver(solver, *, seed: int = 0) -> list[str]:
    """Run every conformance check on a solver plugin class or instance.

    Parameters
    ----------
    solver : Solver class or instance
        A class is instantiated without arguments.
    seed : int
        Seed of the generated problems.

    Returns
    -------
    list of str: the names of the checks that ran.

    Raises
    ------
    AssertionError
        On the first failed check, naming the check and the problem.
    RuntimeError
        When the solver reports itself unavailable here (the reason is in the message).
    """
    cls = solver if isinstance(solver, type) else type(solver)
    ran = ["declaration"]
    _check_declaration(cls)
    found = cls.availability()
    if not found:
        raise RuntimeError(f"{cls.name} is unavailable here, cannot check it: {found.reason}")
    instance = _instance(solver)
    capabilities: Capabilities = instance.capabilities
    overlap = capabilities.max_overlap
    for label, problem in conformance_problems(seed):
        if problem.cap is not None and not capabilities.supports_cap:
            continue
        solution = instance.solve(problem, seed=seed)
        where = f"{cls.name} on {label!r}"
        _check_fields(problem, solution, cls.name, where)
        try:
            check_packing(problem, solution.items, overlap=overlap)
        except AssertionError as error:
            raise AssertionError(f"{where}: invalid expression: {error}") from None
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
        if capabilities.deterministic:
            again = instance.solve(problem, seed=seed)
            assert again.items == solution.items, (
                f"{where}: not deterministic: {solution.items} then {again.items}"
            )
    ran += ["fields", "validity", "brute-force optimum" if capabilities.exact else "objective", "determinism"]
    _check_bad_arguments(instance, cls.name)
    ran.append("bad arguments")
    if capabilities.time_limit:
        _check_time_limit(instance, cls.name, seed)
        ran.append("time limit")
    return ran


def _check_declaration(cls: type) -> None:
    name = getattr(cls, "name", None)
    assert isinstance(name, str) and name, f"{cls.__name__}.name must be a non-empty str, got {name!r}"
    assert isinstance(getattr(cls, "capabilities", None), Capabilities), (
        f"{name}.capabilities must be a solvers.Capabilities"
    )
    found = cls.availability()
    assert isinstance(found, Availability), f"{name}.availability() must return a solvers.Availability"
    assert bool(found) or found.reason, f"{name}: an unavailable solver must say why"


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


def _check_bad_arguments(instance: Solver, name: str) -> None:
    problem = random_problem(5, 10, seed=1)
    for arguments in ({"time_limit": -1.0}, {"time_limit": math.nan}, {"seed": -1}):
        try:
            instance.solve(problem, **arguments)
        except ValueError:
            continue
        raise AssertionError(f"{name}: solve({arguments}) must raise ValueError")


def _check_time_limit(instance: Solver, name: str, seed: int) -> None:
    problem = hard_problem(seed)
    solution = instance.solve(problem, time_limit=0.05, seed=seed)
    where = f"{name} on the hard problem with time_limit=0.05"
    _check_fields(problem, solution, name, where)
    assert solution.termination in (Termination.OPTIMAL, Termination.TIME_LIMIT), (
        f"{where}: ended {solution.termination}"
    )
    assert solution.items, f"{where}: no incumbent"
    check_packing(problem, solution.items)
    assert solution.bound is not None and solution.bound >= solution.objective, (
        f"{where}: bound {solution.bound}"
    )
