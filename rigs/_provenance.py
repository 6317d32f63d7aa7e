"""What a `rigs.Rig` knows besides its geometry, as typed records: where it came from (`Provenance`), the
mesh to draw for it (`Surface`), what cleaning it on load found (`LoadReport`) and the ground truth of a
generated rig (`Truth`) or of a character-specific target (`CharacterRecord`).

Every record is a frozen dataclass; derive a changed one with :func:`dataclasses.replace`. A reader fills
what its format says and leaves the rest at the defaults, which mean "not known" or "not done".
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from rigs._gltf_surface import GltfSurface


#: Metres per unit of the length units a rig's ``provenance.units`` may name (glTF's unit is the metre, USD
#: states its own, OBJ and generated rigs say theirs where known).
METERS_PER_UNIT = {"m": 1.0, "dm": 0.1, "cm": 0.01, "mm": 0.001, "in": 0.0254}


def meters_per_unit(units: str | None) -> float | None:
    """Metres per unit of ``units``: a `METERS_PER_UNIT` name or ``"<factor> m"`` (a USD stage's odd
    ``metersPerUnit``); None when unknown."""
    if units in METERS_PER_UNIT:
        return METERS_PER_UNIT[units]
    number, _, unit = (units or "").partition(" ")
    try:
        factor = float(number)
    except ValueError:
        return None
    return factor if unit == "m" and math.isfinite(factor) and factor > 0 else None


@dataclass(frozen=True)
class GeneratorSettings:
    """The procedural generator's inputs of a generated rig (`rigs.generate`).

    Attributes
    ----------
    preset : str
        The preset's name (``tiny``, ``arkit52``, ... or a custom `rigs.PresetSpec`'s).
    seed : int >= 0
        The generator seed; the same preset and seed give the same rig bit for bit.
    """

    preset: str
    seed: int


@dataclass(frozen=True)
class WarpRecord:
    """The warp a target rig was made with (`rigs.warp`, Carrigan et al. 2020, sec. 5.1).

    Attributes
    ----------
    spec : str
        The preset or spec string given, else a label such as ``"scale:1.3,1,1+local:mouth,0.7"``;
        ``rigs.warp(template, spec)`` makes the same target again.
    definition : mapping
        The steps as JSON-ready data (``{"kind": "compose", "steps": [...]}`` and the like, see
        :mod:`rigs._warp`).
    """

    spec: str
    definition: Mapping[str, Any]


@dataclass(frozen=True)
class ShapeChange:
    """How a character-specific target changed one blendshape (`rigs.Character`): every moving
    displacement is gained by ``exp(w @ log_gains)``, turned about ``axis`` by ``w @ angles`` degrees and
    scaled per axis by ``scale``, with ``w`` the vertex's weights over the record's regions.

    Attributes
    ----------
    damping : float in [0, 1]
        The factor the full change was multiplied by (1 unless the full change would fold a triangle);
        the other fields are already damped.
    log_gains, angles : tuple of float
        One per region of the `CharacterRecord`; angles in degrees.
    axis : (float, float, float)
        The unit turning axis.
    scale : (float, float, float)
        The per-axis factor of the actor's traits.
    """

    damping: float
    log_gains: tuple[float, ...]
    angles: tuple[float, ...]
    axis: tuple[float, float, float]
    scale: tuple[float, float, float]


@dataclass(frozen=True)
class CharacterRecord:
    """The ground truth of a character-specific target (`rigs.Character`): how its blendshapes differ from
    the rig they were made from.

    Attributes
    ----------
    strength : float
        Multiplier of every change.
    seed : int
        The character's seed.
    traits : mapping str -> float
        The actor's ``asymmetry``, ``smile_width``, ``jaw_weight`` and ``brow_range``.
    regions : tuple of str
        The face regions of the gain and angle fields, in the order of each `ShapeChange`'s values.
    shapes : mapping str -> ShapeChange
        The change of every blendshape, by name.
    """

    strength: float
    seed: int
    traits: Mapping[str, float]
    regions: tuple[str, ...]
    shapes: Mapping[str, ShapeChange]


@dataclass(frozen=True, eq=False)
class BaseMesh:
    """The base mesh a rig of MakeHuman ``.target`` files was read over (`rigs._target`).

    Attributes
    ----------
    file : str
        The base OBJ (a path, or ``archive!member``).
    n_vertices : int
        Its vertex count.
    vertex_ids : (N,) int array
        The base-mesh vertex of each rig vertex (all of them in order unless the reader cropped it).
    """

    file: str
    n_vertices: int
    vertex_ids: np.ndarray


@dataclass(frozen=True, eq=False)
class Weld:
    """Vertices a glTF reader merged along UV and normal seams (``load_gltf(weld=True)``).

    Attributes
    ----------
    merged : int
        How many glTF vertices were merged away.
    vertex_map : (V,) int array
        The rig vertex of each glTF vertex.
    """

    merged: int
    vertex_map: np.ndarray


@dataclass(frozen=True)
class Provenance:
    """Where a rig came from and how it was read or made.

    Attributes
    ----------
    source : str
        The file or folder read (``generated:<preset>`` for a generated rig), with what was done to it
        since (``"... warped by big-eyes"``); empty when not known.
    format : str
        The registered format it was read from (``npz``, ``obj-folder``, ``gltf``, ``makehuman-target``,
        ``usd`` or a plugin's); empty for a rig not read from a file.
    units : str or None
        The length unit (``cm``, ``m``, ``dm``, ``unknown`` when a format cannot say); None when nothing
        was recorded.
    license : str or None
        SPDX identifier of the data's licence, when known.
    origin : str or None
        Where the data was first published, when it was taken from elsewhere.
    mesh : str or None
        The mesh read from a file of several: glTF mesh name (or index), USD prim path.
    primitives : tuple of int
        The glTF primitives read as the one mesh.
    transform : str or None
        The world transform applied to the positions, when one was.
    weld : Weld or None
        Vertices merged along seams, when the reader welded.
    decimal_step : float
        The coarsest rounding step of the file's coordinates (OBJ written with a fixed number of
        decimals), 0 when they are not rounded; the noise floor respects it.
    single : bool
        The file holds its coordinates as 32-bit floats (glTF): the rig's float64 values (a node's
        transform applied to them, say) carry no more than a float32's digits, and files written from
        them need no more.
    base : BaseMesh or None
        The base mesh of a ``.target`` rig.
    crop_rings : int or None
        Face rings kept around the vertices some target moves, when the base mesh was cropped.
    generator : GeneratorSettings or None
        The generator's inputs of a generated rig.
    warp : WarpRecord or None
        The warp of a target made by `rigs.warp`.
    character : CharacterRecord or None
        The ground truth of a character-specific target (`rigs.Character`).
    """

    source: str = ""
    format: str = ""
    units: str | None = None
    license: str | None = None
    origin: str | None = None
    mesh: str | None = None
    primitives: tuple[int, ...] = ()
    transform: str | None = None
    weld: Weld | None = None
    decimal_step: float = 0.0
    single: bool = False
    base: BaseMesh | None = None
    crop_rings: int | None = None
    generator: GeneratorSettings | None = None
    warp: WarpRecord | None = None
    character: CharacterRecord | None = None

    @property
    def label(self) -> str:
        """The source, or ``"rig"`` when it is not known: how messages name the rig."""
        return self.source or "rig"


@dataclass(frozen=True, eq=False)
class Surface:
    """The mesh to draw for a rig besides its positions: texture coordinates, normals, groups and materials,
    kept so that files written at an expression's positions look like the rig's own.

    One of two forms, after the file the rig came from:

    Attributes
    ----------
    obj : Path or None
        An OBJ file whose ``v`` lines are the rig's vertices in order (the neutral of an OBJ folder, the
        cropped base mesh of the Face Units rig); read when needed (`rigs.rig_surface`), and used only
        while its positions are still the rig's neutral.
    folder : Path or None
        The folder ``obj`` must lie inside (the rig's folder), None when it may lie anywhere.
    gltf : GltfSurface or None
        What the glTF mesh held besides positions, per glTF vertex; used only while its triangles are
        still the rig's.
    """

    obj: Path | None = None
    folder: Path | None = None
    gltf: GltfSurface | None = None

    def __post_init__(self) -> None:
        if (self.obj is None) == (self.gltf is None):
            raise ValueError("a Surface holds either an OBJ file or a glTF surface")


@dataclass(frozen=True)
class NoiseFloor:
    """The displacements a load zeroed as noise (Carrigan et al. 2020, sec. 4.1 needs empty shapes to be
    truly empty).

    Attributes
    ----------
    relative_floor : float
        The floor asked for, relative to the neutral's bounding-box diagonal (0: nothing zeroed).
    floor : float
        The absolute floor applied (at least two rounding steps of the file's coordinates).
    rounding_step : float
        The file's rounding step (`Provenance.decimal_step`).
    zeroed : mapping str -> int
        Per shape that had any, how many displacements were zeroed.
    """

    relative_floor: float
    floor: float
    rounding_step: float
    zeroed: Mapping[str, int] = field(default_factory=dict)


@dataclass(frozen=True)
class LoadReport:
    """What cleaning a rig on load found (`rigs.load`); doubtful findings are also named in a
    `rigs.RigWarning`.

    Attributes
    ----------
    noise : NoiseFloor
        The displacements zeroed as noise.
    empty_shapes : tuple of str
        Shapes with no displacement left (kept, never dropped).
    degenerate_triangles : int
        Zero-area triangles of the neutral (reported, not fatal).
    identical_shapes : tuple of tuple of str
        Groups of shapes whose displacements are equal at every vertex, in rig order.
    case_twins : tuple of tuple of str
        Groups of shape names equal up to case, in rig order.
    """

    noise: NoiseFloor
    empty_shapes: tuple[str, ...] = ()
    degenerate_triangles: int = 0
    identical_shapes: tuple[tuple[str, ...], ...] = ()
    case_twins: tuple[tuple[str, ...], ...] = ()


@dataclass(frozen=True)
class Truth:
    """The symmetry a generated rig was built with (`rigs.generate`; Carrigan et al. 2020, sec. 4.4).

    Attributes
    ----------
    mirror_pairs : tuple of (left, right)
        Mirror-image shape pairs (sec. 4.4.1).
    spread_mirror_images : tuple of (left, right)
        Mirror images of a midline site moving sideways (``jawLeft``/``jawRight``): they spread over both
        facial halves and are never paired.
    motion_pairs : tuple of (upper, lower)
        Shapes moving the two sides of a sketch towards each other (sec. 4.4.2).
    self_symmetric : tuple of str
        Shapes that are their own mirror image.
    """

    mirror_pairs: tuple[tuple[str, str], ...] = ()
    spread_mirror_images: tuple[tuple[str, str], ...] = ()
    motion_pairs: tuple[tuple[str, str], ...] = ()
    self_symmetric: tuple[str, ...] = ()
