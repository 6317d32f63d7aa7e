"""The public names of `solvers`, read by type checkers and by its lazy loader (`lazy_loader.attach_stub`):
each is imported from its module on first use."""

from ._base import (
    Availability as Availability,
    AvailabilityStatus as AvailabilityStatus,
    Capabilities as Capabilities,
    Result as Result,
    Setting as Setting,
    Solver as Solver,
    cpu_seconds as cpu_seconds,
    no_answer as no_answer,
    package_availability as package_availability,
)
from ._exact import (
    ExactSolver as ExactSolver,
)
from ._loaded import (
    WARM_UP_LIMIT as WARM_UP_LIMIT,
    LoadedSolver as LoadedSolver,
    load as load,
    warm_up as warm_up,
)
from ._minimum import (
    MinimumExpressions as MinimumExpressions,
    OrderedSequence as OrderedSequence,
    minimum_cover_solvers as minimum_cover_solvers,
    minimum_expressions as minimum_expressions,
    ordered_minimum_sequence as ordered_minimum_sequence,
)
from ._model import (
    CliqueModel as CliqueModel,
)
from ._mps import (
    MpsFile as MpsFile,
    column_names as column_names,
    solu_line as solu_line,
    write_mps as write_mps,
)
from ._open import (
    OpenExpression as OpenExpression,
)
from ._refine import (
    Proposal as Proposal,
    RefiningSolver as RefiningSolver,
    refine as refine,
    rejecting as rejecting,
)
from ._registry import (
    SolverUnavailableError as SolverUnavailableError,
    UnknownSolverError as UnknownSolverError,
    add_file as add_file,
    availability as availability,
    get as get,
    info as info,
    names as names,
    refresh as refresh,
    solver_class as solver_class,
)
from ._termination import (
    Termination as Termination,
)
from ._worker import (
    Worker as Worker,
    WorkerDied as WorkerDied,
    WorkerError as WorkerError,
    wait_for_workers as wait_for_workers,
    worker as worker,
)
