"""A heuristic solver plugin: first fit in index order (Carrigan et al. 2020, eq. 3b)."""

from packing import Termination
from solvers import Availability, Capabilities, OpenExpression, Result


class FirstFitSolver:
    """Take every item, in index order, that still fits the expression."""

    name = "example-first-fit"
    capabilities = Capabilities(exact=False, time_limit=False)

    @classmethod
    def availability(cls):
        return Availability.available("0.1.0")

    def solve(self, problem, *, time_limit=None, seed=0):
        expression = OpenExpression(problem)  # keeps eq. 3b, the cap and the apart pairs
        for item in range(problem.n_items):
            if expression.fits(item):
                expression.add(item)
        return Result(expression.items, Termination.COMPLETED)
