"""The public names of `solvers`, read by type checkers and by its lazy loader (`lazy_loader.attach_stub`):
each is imported from its module on first use."""

from ._base import (
    Availability as Availability,
)
from ._base import (
    AvailabilityStatus as AvailabilityStatus,
)
from ._base import (
    Capabilities as Capabilities,
)
from ._base import (
    Result as Result,
)
from ._base import (
    Setting as Setting,
)
from ._base import (
    Solver as Solver,
)
from ._base import (
    cpu_seconds as cpu_seconds,
    no_answer as no_answer,
)
from ._base import (
    package_availability as package_availability,
)
from ._exact import (
    ExactSolver as ExactSolver,
)
from ._loaded import (
    LoadedSolver as LoadedSolver,
)
from ._loaded import (
    load as load,
)
from ._minimum import (
    MinimumExpressions as MinimumExpressions,
)
from ._minimum import (
    OrderedSequence as OrderedSequence,
)
from ._minimum import (
    minimum_cover_solvers as minimum_cover_solvers,
)
from ._minimum import (
    minimum_expressions as minimum_expressions,
)
from ._minimum import (
    ordered_minimum_sequence as ordered_minimum_sequence,
)
from ._model import (
    CliqueModel as CliqueModel,
)
from ._mps import (
    MpsFile as MpsFile,
)
from ._mps import (
    column_names as column_names,
)
from ._mps import (
    solu_line as solu_line,
)
from ._mps import (
    write_mps as write_mps,
)
from ._open import (
    OpenExpression as OpenExpression,
)
from ._refine import (
    Proposal as Proposal,
)
from ._refine import (
    RefiningSolver as RefiningSolver,
)
from ._refine import (
    refine as refine,
)
from ._refine import (
    rejecting as rejecting,
)
from ._registry import (
    SolverUnavailableError as SolverUnavailableError,
)
from ._registry import (
    UnknownSolverError as UnknownSolverError,
)
from ._registry import (
    add_file as add_file,
)
from ._registry import (
    availability as availability,
)
from ._registry import (
    get as get,
)
from ._registry import (
    info as info,
)
from ._registry import (
    names as names,
)
from ._registry import (
    refresh as refresh,
)
from ._registry import (
    solver_class as solver_class,
)
from ._termination import (
    Termination as Termination,
)
from ._worker import (
    Worker as Worker,
)
from ._worker import (
    WorkerDied as WorkerDied,
)
from ._worker import (
    WorkerError as WorkerError,
)
from ._worker import (
    wait_for_workers as wait_for_workers,
)
from ._worker import (
    worker as worker,
)
