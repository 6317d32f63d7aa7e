"""Expression packing (Carrigan et al. 2020, sec. 4): binary blendshapes, importance, symmetry, the
packing problem and its presolve, the expression sequence (Algorithm 1), the independent checker, and the
three as one checked pipeline (`Pipeline`).

Names are imported from their modules on first use (PEP 562): ``from packing import PackingProblem``
(what a solver plugin needs) loads neither the rig analysis, nor the rig loaders, nor networkx."""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
