"""Solver backends for expression packing (Carrigan et al. 2020, sec. 4.5) behind one plugin interface.

Solvers are plugins registered in the ``harness.solvers`` entry-point group; `names` lists them without
importing any backend, `get` returns a ready instance, `info` reports availability and capabilities.
Beyond single expressions: artist refinement (sec. 4.5.3, `refine`, `RefiningSolver`) and the minimum
number of expressions with its ordered sequence (`minimum_expressions`, `ordered_minimum_sequence`).
The conformance checks for plugins live in `solvers.testing`. `Worker` runs functions in a persistent child
process that may crash or be killed without taking its caller along (a backend that cannot share a process
with the others, the harness's grid cells).

The plugin kit: a plugin's ``solve`` returns a `Result` (items, `Termination`, bound); `load` (which `get`
applies) checks its arguments and turns its answer into a `packing.Solution` once for every plugin. An
exact plugin subclasses `ExactSolver` and solves the presolved `CliqueModel`; a heuristic fills an
`OpenExpression`, which keeps eq. 3b, the cap and the apart pairs; `package_availability` answers
``availability()`` without importing the backend. `write_mps` writes a `CliqueModel` as an MPS file and
`solu_line` its MIPLIB ``.solu`` line, for solvers outside the harness.

Names are imported from their modules on first use (PEP 562): listing the plugins imports neither a
backend nor the minimum-expression machinery.
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
