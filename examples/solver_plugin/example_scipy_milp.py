"""An exact solver plugin: eq. 3 after presolve with SciPy's MILP interface (HiGHS inside SciPy)."""

import numpy as np

from packing import Termination
from solvers import Capabilities, ExactSolver, Result, package_availability


class ScipyMilpSolver(ExactSolver):
    """Maximise the importance sum over the clique rows and the cap row, x binary."""

    name = "example-scipy-milp"
    capabilities = Capabilities(exact=True, time_limit=True)

    @classmethod
    def availability(cls):
        return package_availability("scipy")

    def solve_model(self, model, *, time_limit, seed):
        from scipy.optimize import milp

        rows, options = model.constraint(), {"mip_rel_gap": 0.0}
        options |= {} if time_limit is None else {"time_limit": time_limit}
        found = milp(-model.weights, integrality=1, bounds=(0, 1), constraints=rows, options=options)
        if found.x is None:
            return Result((), Termination.ERROR, message=found.message)
        stopped = Termination.OPTIMAL if found.status == 0 else Termination.TIME_LIMIT
        return Result(np.flatnonzero(found.x > 0.5), stopped, bound=-found.mip_dual_bound)
