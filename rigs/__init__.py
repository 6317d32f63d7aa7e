"""Blendshape rigs: the `Rig` value and its records (provenance, surface, load report, truth), loaders and
writers, the procedural generator, warps, mirror map and left/right names, the registry of rig formats, the
frontal camera of a face.

Names are attached lazily (lazy_loader): ``import rigs`` costs nothing until a name is used, so that
listing plugins and presets does not import SciPy's spatial or sparse modules.
"""

from typing import TYPE_CHECKING

import lazy_loader

if TYPE_CHECKING:
    from rigs._camera import frontal_camera, three_quarter_camera
    from rigs._character import Character
    from rigs._faceunits import cached_faceunits, fetch_faceunits, load_faceunits
    from rigs._format_table import RigFormat
    from rigs._formats import detect_format, formats, register_format
    from rigs._generate import PRESETS, PresetSpec, generate
    from rigs._gltf_surface import GltfSurface
    from rigs._gltf_write import glb_bytes
    from rigs._inputs import RigInputs
    from rigs._io import load, load_with_inputs, moving_everywhere, save
    from rigs._mirror import mirror_map
    from rigs._names import compare_name_pairs, mirror_name_pairs, side_of
    from rigs._obj import decimal_step, parse_obj
    from rigs._obj_surface import ObjSurface, plain_surface, read_surface, rig_surface
    from rigs._provenance import (
        BaseMesh,
        CharacterRecord,
        GeneratorSettings,
        LoadReport,
        NoiseFloor,
        Provenance,
        ShapeChange,
        Surface,
        Truth,
        WarpRecord,
        Weld,
    )
    from rigs._regions import read_regions, regions_from_mapping
    from rigs._rig import Rig, RigError, RigWarning, bounding_box, vector_lengths
    from rigs._safe import folder_relative, read_bytes, read_json
    from rigs._vertex_order import VertexOrder
    from rigs._warp import WARPS, Compose, LocalScale, Scale, Warp, warp

__getattr__, __dir__, __all__ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "_camera": ["frontal_camera", "three_quarter_camera"],
        "_character": ["Character"],
        "_format_table": ["RigFormat"],
        "_formats": ["detect_format", "formats", "register_format"],
        "_faceunits": ["cached_faceunits", "fetch_faceunits", "load_faceunits"],
        "_generate": ["PRESETS", "PresetSpec", "generate"],
        "_io": ["load", "load_with_inputs", "moving_everywhere", "save"],
        "_inputs": ["RigInputs"],
        "_mirror": ["mirror_map", "mirror_plane"],
        "_names": ["compare_name_pairs", "mirror_name_pairs", "side_of"],
        "_gltf_surface": ["GltfSurface"],
        "_gltf_write": ["glb_bytes"],
        "_obj": ["decimal_step", "parse_obj"],
        "_obj_surface": ["ObjSurface", "plain_surface", "read_surface", "rig_surface"],
        "_provenance": [
            "BaseMesh",
            "CharacterRecord",
            "GeneratorSettings",
            "LoadReport",
            "NoiseFloor",
            "Provenance",
            "ShapeChange",
            "Surface",
            "Truth",
            "WarpRecord",
            "Weld",
        ],
        "_regions": ["read_regions", "regions_from_mapping"],
        "_safe": ["folder_relative", "read_bytes", "read_json"],
        "_rig": ["Rig", "RigError", "RigWarning", "bounding_box", "vector_lengths"],
        "_vertex_order": ["VertexOrder"],
        "_warp": ["WARPS", "Compose", "LocalScale", "Scale", "Warp", "warp"],
    },
)
