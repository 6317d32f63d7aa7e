"""The TD's scanning session: ``harness pack`` chooses the expressions an actor is scanned in (Carrigan et
al. 2020, Algorithm 1 with one solver, sec. 4.5's refinement and second pass) and writes the session folder:
``expressions.json``, one OBJ per expression, the pictures and the printable scan sheet.

`pack` of a `PackConfig` is the library entry (`session.cli` the command); the solver runs in a worker
process of its own (`session._solver`), the anatomical rules and the artist's constraints are merged in
`session._constraints`, and the folder's files are made by `session._files`.

Names are imported from their modules on first use (PEP 562), so that ``harness --help`` lists ``pack``
without importing NumPy.
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
