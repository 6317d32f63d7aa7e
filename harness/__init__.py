"""The `harness` command and its library: the experiment grid, executors, the records store, resume.

Runs write ``OUT/run.json`` and ``OUT/records/*.parquet``; `read_run` and `read_records` read them back (the
columns are documented in `harness._records`); the tables made from them are the `reports` package's. The
harness runs rigs through `packing`, `solvers` and `transfer` and never computes results itself. Beside
them, the pieces other commands build on (`session`'s ``harness pack``, plugin commands): the shared options
(`packing_options`, `constraint_options`, `DURATION`, ...), the output folder (`claim`), the plugins
(`load_solver`) and a solver in a worker process of its own (`IsolatedSolver`).

Names are imported from their modules on first use (PEP 562), so that ``harness --help`` and the commands
that need no records store start without importing pandas and pyarrow.
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
