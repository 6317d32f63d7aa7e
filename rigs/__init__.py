"""Blendshape rigs: the `Rig` value, loaders and writers, the procedural generator, warps, mirror map."""

from rigs._generate import PRESETS, generate
from rigs._io import load, save
from rigs._mirror import mirror_map
from rigs._rig import Rig, RigError
from rigs._warp import WARPS, warp

__all__ = ["PRESETS", "WARPS", "Rig", "RigError", "generate", "load", "mirror_map", "save", "warp"]
