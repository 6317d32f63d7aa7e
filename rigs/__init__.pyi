"""The public names of `rigs`, read by type checkers and by its lazy loader (`lazy_loader.attach_stub`):
each is imported from its module on first use."""

from ._argument import (
    FETCHED_RIGS as FETCHED_RIGS,
    argument_paths as argument_paths,
    fetched_path as fetched_path,
    is_rig_path as is_rig_path,
    resolve as resolve,
)
from ._camera import (
    frontal_camera as frontal_camera,
    three_quarter_camera as three_quarter_camera,
)
from ._character import (
    Character as Character,
)
from ._faceunits import (
    cached_faceunits as cached_faceunits,
    fetch_faceunits as fetch_faceunits,
    load_faceunits as load_faceunits,
)
from ._format_table import (
    RigFormat as RigFormat,
)
from ._formats import (
    detect_format as detect_format,
    formats as formats,
    register_format as register_format,
)
from ._generate import (
    PRESETS as PRESETS,
    PresetSpec as PresetSpec,
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
    load_with_inputs as load_with_inputs,
    moving_everywhere as moving_everywhere,
    save as save,
)
from ._mirror import (
    mirror_map as mirror_map,
    mirror_plane as mirror_plane,
)
from ._names import (
    compare_name_pairs as compare_name_pairs,
    mirror_name_pairs as mirror_name_pairs,
    side_of as side_of,
)
from ._obj import (
    decimal_step as decimal_step,
    parse_obj as parse_obj,
)
from ._obj_surface import (
    ObjSurface as ObjSurface,
    plain_surface as plain_surface,
    read_surface as read_surface,
    rig_surface as rig_surface,
)
from ._provenance import (
    BaseMesh as BaseMesh,
    CharacterRecord as CharacterRecord,
    GeneratorSettings as GeneratorSettings,
    LoadReport as LoadReport,
    NoiseFloor as NoiseFloor,
    Provenance as Provenance,
    ShapeChange as ShapeChange,
    Surface as Surface,
    Truth as Truth,
    WarpRecord as WarpRecord,
    Weld as Weld,
)
from ._regions import (
    read_regions as read_regions,
    regions_from_mapping as regions_from_mapping,
)
from ._rig import (
    Rig as Rig,
    RigError as RigError,
    RigWarning as RigWarning,
    bounding_box as bounding_box,
    vector_lengths as vector_lengths,
)
from ._safe import (
    folder_relative as folder_relative,
    read_bytes as read_bytes,
    read_json as read_json,
)
from ._vertex_order import (
    VertexOrder as VertexOrder,
)
from ._warp import (
    WARPS as WARPS,
    Compose as Compose,
    LocalScale as LocalScale,
    Scale as Scale,
    Warp as Warp,
    warp as warp,
)
