"""Blendshape rigs: the `Rig` value, loaders and writers, the procedural generator, warps, mirror map and
left/right names, the frontal camera of a face."""

from rigs._atomic import atomic_write
from rigs._camera import frontal_camera, three_quarter_camera
from rigs._character import Character
from rigs._faceunits import cached_faceunits, fetch_faceunits, load_faceunits
from rigs._generate import PRESETS, PresetSpec, generate
from rigs._io import load, save
from rigs._mirror import mirror_map
from rigs._names import compare_name_pairs, mirror_name_pairs, side_of
from rigs._obj import ObjSurface, plain_surface, rig_surface
from rigs._regions import read_regions, regions_from_mapping
from rigs._rig import Rig, RigError, RigWarning
from rigs._warp import WARPS, Compose, LocalScale, Scale, warp

__all__ = [
    "atomic_write",
    "Character",
    "PRESETS",
    "WARPS",
    "Compose",
    "ObjSurface",
    "LocalScale",
    "PresetSpec",
    "Rig",
    "RigError",
    "RigWarning",
    "cached_faceunits",
    "fetch_faceunits",
    "frontal_camera",
    "generate",
    "load",
    "load_faceunits",
    "mirror_map",
    "plain_surface",
    "rig_surface",
    "Scale",
    "compare_name_pairs",
    "mirror_name_pairs",
    "read_regions",
    "regions_from_mapping",
    "save",
    "side_of",
    "three_quarter_camera",
    "warp",
]
