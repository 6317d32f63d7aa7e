"""Blendshape rigs: the `Rig` value and its records (provenance, surface, load report, truth), loaders and
writers, the procedural generator, warps, mirror map and left/right names, the registry of rig formats, the
frontal camera of a face.

Names are attached lazily (lazy_loader): ``import rigs`` costs nothing until a name is used, so that
listing plugins and presets does not import SciPy's spatial or sparse modules.
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
