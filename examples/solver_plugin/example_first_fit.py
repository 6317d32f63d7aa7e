"""An example solver plugin: pack items first-fit in index order (Carrigan et al. 2020, eq. 3b)."""

from __future__ import annotations

import time
from typing import ClassVar

import numpy as np

from packing import PackingProblem, Solution, Termination
from solvers import Availability, Capabilities


class FirstFitSolver:
    """Take every item, in index order, whose vertices are still free and whose shapes fit the cap."""

    name: ClassVar[str] = "example-first-fit"
    capabilities: ClassVar[Capabilities] = Capabilities(exact=False, time_limit=False)

    @classmethod
    def availability(cls) -> Availability:
        return Availability.available("0.1.0")

    def solve(self, problem: PackingProblem, *, time_limit: float | None = None, seed: int = 0) -> Solution:
        if time_limit is not None and not time_limit > 0:
            raise ValueError(f"time_limit must be positive, got {time_limit!r}")
        if not 0 <= seed < 2**31:
            raise ValueError(f"seed must be in [0, 2**31), got {seed!r}")
        start = time.perf_counter()
        free = np.ones(problem.incidence.shape[1], dtype=bool)
        room = np.inf if problem.cap is None else problem.cap
        chosen = []
        for item, count in enumerate(problem.item_shape_counts.tolist()):
            vertices = problem.incidence[item].indices
            if count <= room and free[vertices].all():
                free[vertices] = False
                room -= count
                chosen.append(item)
        return Solution(
            items=tuple(chosen),
            shapes=problem.shapes_of(chosen),
            objective=problem.objective(chosen),
            bound=None,
            termination=Termination.COMPLETED,
            solve_time=time.perf_counter() - start,
            backend=self.name,
            version="0.1.0",
        )
