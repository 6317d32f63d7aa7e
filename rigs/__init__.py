"""Blendshape rigs: the `Rig` value, loaders and writers, the procedural generator, warps, mirror map."""

from rigs._faceunits import fetch_faceunits, load_faceunits
from rigs._generate import PRESETS, PresetSpec, generate
from rigs._io import load, save
from rigs._mirror import mirror_map
from rigs._rig import Rig, RigError
from rigs._warp import WARPS, Compose, LocalScale, Scale, warp

__all__ = [
    "PRESETS",
    "WARPS",
    "Compose",
    "LocalScale",
    "PresetSpec",
    "Rig",
    "RigError",
    "fetch_faceunits",
    "generate",
    "load",
    "load_faceunits",
    "mirror_map",
    "Scale",
    "save",
    "warp",
]
