"""The public names of `rigs`, read by type checkers and by its lazy loader (`lazy_loader.attach_stub`):
each is imported from its module on first use."""

from ._camera import (
    frontal_camera as frontal_camera,
)
from ._camera import (
    three_quarter_camera as three_quarter_camera,
)
from ._character import (
    Character as Character,
)
from ._faceunits import (
    cached_faceunits as cached_faceunits,
)
from ._faceunits import (
    fetch_faceunits as fetch_faceunits,
)
from ._faceunits import (
    load_faceunits as load_faceunits,
)
from ._format_table import (
    RigFormat as RigFormat,
)
from ._formats import (
    detect_format as detect_format,
)
from ._formats import (
    formats as formats,
)
from ._formats import (
    register_format as register_format,
)
from ._generate import (
    PRESETS as PRESETS,
)
from ._generate import (
    PresetSpec as PresetSpec,
)
from ._generate import (
    generate as generate,
)
from ._gltf_surface import (
    GltfSurface as GltfSurface,
)
from ._gltf_write import (
    glb_bytes as glb_bytes,
)
from ._inputs import (
    RigInputs as RigInputs,
)
from ._io import (
    load as load,
)
from ._io import (
    load_with_inputs as load_with_inputs,
)
from ._io import (
    moving_everywhere as moving_everywhere,
)
from ._io import (
    save as save,
)
from ._mirror import (
    mirror_map as mirror_map,
)
from ._mirror import (
    mirror_plane as mirror_plane,
)
from ._names import (
    compare_name_pairs as compare_name_pairs,
)
from ._names import (
    mirror_name_pairs as mirror_name_pairs,
)
from ._names import (
    side_of as side_of,
)
from ._obj import (
    decimal_step as decimal_step,
)
from ._obj import (
    parse_obj as parse_obj,
)
from ._obj_surface import (
    ObjSurface as ObjSurface,
)
from ._obj_surface import (
    plain_surface as plain_surface,
)
from ._obj_surface import (
    read_surface as read_surface,
)
from ._obj_surface import (
    rig_surface as rig_surface,
)
from ._provenance import (
    BaseMesh as BaseMesh,
)
from ._provenance import (
    CharacterRecord as CharacterRecord,
)
from ._provenance import (
    GeneratorSettings as GeneratorSettings,
)
from ._provenance import (
    LoadReport as LoadReport,
)
from ._provenance import (
    NoiseFloor as NoiseFloor,
)
from ._provenance import (
    Provenance as Provenance,
)
from ._provenance import (
    ShapeChange as ShapeChange,
)
from ._provenance import (
    Surface as Surface,
)
from ._provenance import (
    Truth as Truth,
)
from ._provenance import (
    WarpRecord as WarpRecord,
)
from ._provenance import (
    Weld as Weld,
)
from ._regions import (
    read_regions as read_regions,
)
from ._regions import (
    regions_from_mapping as regions_from_mapping,
)
from ._rig import (
    Rig as Rig,
)
from ._rig import (
    RigError as RigError,
)
from ._rig import (
    RigWarning as RigWarning,
)
from ._rig import (
    bounding_box as bounding_box,
)
from ._rig import (
    vector_lengths as vector_lengths,
)
from ._safe import (
    folder_relative as folder_relative,
)
from ._safe import (
    read_bytes as read_bytes,
)
from ._safe import (
    read_json as read_json,
)
from ._vertex_order import (
    VertexOrder as VertexOrder,
)
from ._warp import (
    WARPS as WARPS,
)
from ._warp import (
    Compose as Compose,
)
from ._warp import (
    LocalScale as LocalScale,
)
from ._warp import (
    Scale as Scale,
)
from ._warp import (
    Warp as Warp,
)
from ._warp import (
    warp as warp,
)
