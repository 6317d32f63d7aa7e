"""The largest value of every number a run takes, whether it comes from the command line (`harness._cli_types`
bounds each option as it is parsed) or from a `RunConfig` (`check_bounds`, before any cell is made): a
number past them would not fit a records column, would overflow a wait, or would make a grid that never
finishes being listed."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from registry import HarnessError

if TYPE_CHECKING:
    from harness._grid import RunConfig

#: Largest solver seed: the solvers take a 32-bit signed seed (CP-SAT, HiGHS, the heuristics' generators);
#: also the largest seed of the scan-like examples (repetition r adds r, within the records' 64 bits).
SEED_MAX = 2**31 - 1
#: Most seeds a seed list expands to (each one a grid axis value: thousands of runs already).
SEEDS_MAX = 10_000
#: Largest seed of a generated rig or actor: the records keep seeds as 64-bit integers.
RIG_SEED_MAX = 2**63 - 1
#: Most repetitions or permutations of a run (each a grid axis: every value multiplies the cells).
AXIS_MAX = 1_000
#: Most local worker processes (or Dask workers started for a run).
JOBS_MAX = 256
#: Most expressions of a sequence (and the largest J of a transfer, a cap on shapes per expression): far
#: beyond any rig's shape count, within every column type of the records.
COUNT_MAX = 100_000
#: Most cells of one run's grid.
GRID_MAX = 1_000_000


def check_bounds(config: RunConfig) -> None:
    """Refuse a configuration with a number past its bound, or a grid of more than `GRID_MAX` cells.

    Raises
    ------
    HarnessError
        Naming the option, its value and its bound.
    """
    limits = [
        ("--repetitions", [config.repetitions], AXIS_MAX),
        ("--permutations", [config.permutations], AXIS_MAX),
        ("--jmax", [] if config.jmax is None else [config.jmax], COUNT_MAX),
        ("--j-values", list(config.j_values), COUNT_MAX),
        ("--cap", [cap for cap in config.cap if cap is not None], COUNT_MAX),
        ("--solver-seed", [config.solver_seed], SEED_MAX),
        ("--scan-seed", [config.scan_seed], SEED_MAX),
        ("--seeds", list(config.seed), RIG_SEED_MAX),
    ]
    for option, values, largest in limits:
        for value in values:
            if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= largest:
                raise HarnessError(f"{option} must be an integer from 0 to {largest}, got {value!r}")
    if len(config.seed) > SEEDS_MAX:
        raise HarnessError(f"--seeds gives {len(config.seed)} seeds, more than {SEEDS_MAX}")
    axes = [
        config.rigs, config.seed, config.warps, config.solvers, config.mu, config.alpha, config.beta,
        config.symmetry, config.importance, config.cap, config.distortion, config.examples,
    ]  # fmt: skip
    cells = math.prod(len(axis) for axis in axes) * config.repetitions * config.permutations
    cells *= (2 if config.replay else 1) * (1 + len(config.variations))
    if cells > GRID_MAX:
        raise HarnessError(
            f"the grid has {cells:,} cells (rigs x seeds x warps x solvers x settings x repetitions x "
            f"permutations), more than {GRID_MAX:,}; give fewer values"
        )
