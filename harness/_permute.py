"""Item order as a source of performance variability (SCIP's ``PERMUTE``): ``harness run --permutations N``.

Cell ``permutation`` p > 0 hands its solver every problem with the items shuffled (`item_order`, seeded
by p) and maps the answer back to the problem's own items (`packing.PackingProblem.permuted`), so an exact
solver's objectives do not change and only its times may; permutation 0 is the order as built.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from packing import PackingProblem, Solution
    from solvers import Availability, LoadedSolver


def item_order(n_items: int, permutation: int) -> np.ndarray:
    """The item order of permutation ``permutation``: item i of the shuffled problem is ``order[i]``.

    Permutation 0 is the identity; p > 0 a uniformly random order drawn from a generator seeded by p.
    """
    if permutation == 0:
        return np.arange(n_items)
    return np.random.default_rng(permutation).permutation(n_items)


class Permuted:
    """A solver wrapper that solves every problem in the item order of one permutation.

    Parameters
    ----------
    inner : LoadedSolver
        The cell's solver.
    permutation : int
        Positive permutation index (`item_order`).
    """

    def __init__(self, inner: LoadedSolver, permutation: int) -> None:
        self.inner = inner
        self.permutation = permutation
        self.name = inner.name
        self.capabilities = inner.capabilities

    def availability(self) -> Availability:
        """The inner solver's availability."""
        return self.inner.availability()

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Solution:
        """The inner solve of the shuffled problem, its items mapped back to ``problem``'s."""
        order = item_order(problem.n_items, self.permutation)
        solution = self.inner.solve(problem.permuted(order), time_limit=time_limit, seed=seed)
        return dataclasses.replace(solution, items=tuple(sorted(int(order[i]) for i in solution.items)))


def permuted_solver(solver: LoadedSolver, permutation: int) -> LoadedSolver | Permuted:
    """``solver`` itself for permutation 0, else it wrapped in `Permuted`."""
    return solver if permutation == 0 else Permuted(solver, permutation)
