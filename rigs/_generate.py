"""Procedural blendshape rigs sized like the paper's test cases (Carrigan et al. 2020, sec. 5.1, Table 2).

`generate` builds a face-like, exactly mirror-symmetric surface (`rigs._face_mesh`) and evaluates a
catalogue of local FACS/ARKit-style blendshapes on it (`rigs._shape_library`). Every component is a smooth
bump, exactly zero outside its support, so each shape has the static, smoothing and active vertices of the
paper's Fig. 2 (sec. 4.1). The rig's ``truth`` says which shapes are mirror pairs (eqs. 9-10),
motion pairs (eqs. 11-12) and self-symmetric, so symmetry detection (sec. 4.4) can be scored.
"""

from __future__ import annotations

import zlib
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from registry import HarnessError
from rigs._face_mesh import MOTION_REGION_PAIRS, FaceLayout, FaceMesh, build_face_mesh
from rigs._provenance import GeneratorSettings, Provenance, Truth
from rigs._rig import Rig
from rigs._shape_library import JITTER, MOTIONS, Component, ShapeSpec, Site, catalogue, face_sites, select

#: Hinge of the jaw rotation relative to the lip line: (height above it, depth behind the face), cm.
_JAW_HINGE = (2.5, -8.5)
#: Smallest vertex count whose grid still separates the features.
_MIN_VERTICES = 200
#: Shapes nearer than this cosine to being a motion pair (threshold -0.985, eq. 12) are re-drawn.
_STRAY_COSINE = -0.95
#: Binary-blendshape thresholds at which no stray motion pair may exist (eq. 2, sec. 5.2: 0.25-0.4).
_MU_RANGE = (0.25, 0.3, 0.4)
_MAX_REDRAWS = 50


@dataclass(frozen=True)
class PresetSpec:
    """A procedural rig preset.

    Attributes
    ----------
    name : str
    n_vertices : int
        Target vertex count N; the generated mesh is within 2% of it.
    n_shapes : int
        Exact blendshape count K.
    description : str
    catalogue : str
        Shape catalogue: ``facs`` (FACS-style names with ``_L``/``_R``), ``arkit52`` or ``tiny``.
    layout : FaceLayout
        Face proportions.
    amplitude : float
        Scale of every displacement (a toon moves more).
    """

    name: str
    n_vertices: int
    n_shapes: int
    description: str
    catalogue: str = "facs"
    layout: FaceLayout = field(default_factory=FaceLayout)
    amplitude: float = 1.0


PRESETS: Mapping[str, PresetSpec] = {
    spec.name: spec
    for spec in (
        PresetSpec(
            "male",
            7366,
            73,
            "Paper's Male test case: hand-sculpted production rig (N=7366, K=73).",
            layout=FaceLayout(half_width=7.6, nose_projection=2.6, mouth_half_width=2.5),
        ),
        PresetSpec(
            "toon",
            11680,
            65,
            "Paper's Toon test case: stylised character, big eyes, wide mouth (N=11680, K=65).",
            layout=FaceLayout(
                half_width=7.8,
                eye_x=3.4,
                eye_half_width=1.8,
                eye_opening=0.7,
                nose_projection=1.6,
                mouth_half_width=2.8,
                mouth_opening=0.25,
            ),
            amplitude=1.3,
        ),
        PresetSpec(
            "female",
            5034,
            265,
            "Paper's Female test case: scanned digital double, many shapes (N=5034, K=265).",
            layout=FaceLayout(half_width=7.0, eye_half_width=1.45, nose_projection=2.2, mouth_half_width=2.3),
        ),
        PresetSpec(
            "digidouble",
            5131,
            161,
            "Paper's DigiDouble test case: the shapes two scanned characters share (N=5131, K=161).",
            layout=FaceLayout(half_width=7.1, eye_half_width=1.4, nose_projection=2.3, mouth_half_width=2.35),
        ),
        PresetSpec(
            "film",
            20000,
            1000,
            "Film-scale rig for the speed benchmarks: the Female layout with 1,000 shapes (N=20000, K=1000).",
            layout=FaceLayout(half_width=7.0, eye_half_width=1.45, nose_projection=2.2, mouth_half_width=2.3),
        ),
        PresetSpec(
            "dense",
            100000,
            265,
            "Dense-mesh rig for the speed benchmarks: the Female shapes on 100k vertices (N=100000, K=265).",
            layout=FaceLayout(half_width=7.0, eye_half_width=1.45, nose_projection=2.2, mouth_half_width=2.3),
        ),
        PresetSpec("arkit52", 1220, 52, "The 52 ARKit blendshapes on an ARKit-sized face mesh.", "arkit52"),
        PresetSpec(
            "tiny",
            600,
            12,
            "Small rig for fast tests: a mirror pair, self-symmetric and motion pairs.",
            "tiny",
        ),
    )
}


def generate(preset: str | PresetSpec, seed: int = 0) -> Rig:
    """Generate a procedural blendshape rig.

    Parameters
    ----------
    preset : str or PresetSpec
        A name in `PRESETS` (``male``, ``toon``, ``female``, ``digidouble``, ``film``, ``dense``,
        ``arkit52``, ``tiny``) or a custom `PresetSpec`.
    seed : int >= 0
        Seeds the placement, size, amplitude and direction jitter of every shape. The same preset and
        seed give the same rig bit for bit.

    Returns
    -------
    Rig
        Units are centimetres. ``regions`` holds the motion-symmetry sketches (``upper_lip``,
        ``lower_lip``, ``upper_eyelid_L/R``, ``lower_eyelid_L/R``). ``landmarks`` holds the
        ``eye_L``, ``eye_R``, ``mouth`` and ``nose`` centres; ``provenance`` the ``source``
        (``generated:<preset>``), the ``units`` and the ``generator``'s preset and seed; ``truth``
        (`rigs.Truth`) the ``mirror_pairs`` (sec. 4.4.1 pairs), the ``spread_mirror_images`` (mirror
        images of a midline site moving sideways, e.g. jawLeft/jawRight: they spread over both halves and
        are never paired), the ``motion_pairs`` (upper, lower) and the ``self_symmetric`` names.

    Raises
    ------
    ValueError
        For an unknown preset name, a negative or non-integer seed, or a spec too small to build.

    Examples
    --------
    >>> rig = generate("tiny", seed=3)
    >>> rig.n_shapes, rig.provenance.units
    (12, 'cm')

    Notes
    -----
    Each component is evaluated over all vertices in O(N) numpy operations: O(K N) in all. A mirror pair
    is built once and reflected (``R dv[mirror]``), self-symmetric shapes are symmetrised, so the truth
    holds exactly, not approximately. Random variants that would come near forming a motion pair other
    than the planted ones (cos < -0.95 at mu = 0.25, 0.3 or 0.4) are drawn again from the same stream, so
    a detector following eqs. 9-12 finds exactly the truth whether or not it lets mirror-paired shapes
    into motion pairs and however little of a candidate lies in its sketch.
    """
    spec = _preset(preset)
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise HarnessError(f"seed must be a non-negative integer, got {seed!r}")
    if spec.n_vertices < _MIN_VERTICES or spec.n_shapes < 0:
        raise HarnessError(
            f"preset {spec.name!r}: need n_vertices >= {_MIN_VERTICES} and n_shapes >= 0, "
            f"got {spec.n_vertices} and {spec.n_shapes}"
        )
    mesh = build_face_mesh(spec.n_vertices, spec.layout)
    sites = face_sites(mesh.layout)
    shapes = catalogue(spec.catalogue, mesh.layout)
    chosen = select(shapes.shapes, spec.n_shapes)
    rng = np.random.default_rng([int(seed), zlib.crc32(spec.name.encode())])

    names = [name for shape in chosen for name in shape.names]
    entry_of = np.repeat(np.arange(len(chosen)), [len(shape.names) for shape in chosen])
    present = set(names)
    motion_pairs = [pair for pair in shapes.motion_pairs if set(pair) <= present]
    planned = {frozenset(names.index(name) for name in pair) for pair in motion_pairs}

    deltas = np.empty((spec.n_shapes, mesh.n_vertices, 3))
    redraw = set(range(len(chosen)))
    for _attempt in range(_MAX_REDRAWS):
        for entry in sorted(redraw):
            deltas[entry_of == entry] = _evaluate(chosen[entry], mesh, sites, rng, spec.amplitude)
        strays = _stray_motion_pairs(deltas, mesh.regions, planned)
        redraw = {int(entry_of[k]) for pair in strays for k in pair if chosen[entry_of[k]].varies}
        if not strays:
            break
        if not redraw:
            culprits = ", ".join(f"{names[k]}/{names[m]}" for k, m in strays)
            raise RuntimeError(
                f"preset {spec.name!r}: planned shapes form unintended motion pairs: {culprits}"
            )
    else:
        raise RuntimeError(f"preset {spec.name!r}: could not place shapes clear of motion pairs")

    # A mirror image of a midline site moving sideways (jawLeft/jawRight) spreads over both facial halves:
    # sec. 4.4.1 never pairs those (their sum cancels), so the truth lists them apart from the pairs.
    spread = [shape.names for shape in chosen if shape.is_pair and _on_midline(shape, sites)]
    mirror_pairs = [shape.names for shape in chosen if shape.is_pair and shape.names not in spread]
    self_symmetric = [shape.names[0] for shape in chosen if shape.self_symmetric]

    truth = Truth(
        mirror_pairs=tuple(tuple(pair) for pair in mirror_pairs),
        spread_mirror_images=tuple(tuple(pair) for pair in spread),
        motion_pairs=tuple(tuple(pair) for pair in motion_pairs),
        self_symmetric=tuple(self_symmetric),
    )
    provenance = Provenance(
        source=f"generated:{spec.name}",
        units="cm",
        generator=GeneratorSettings(preset=spec.name, seed=int(seed)),
    )
    return Rig(
        mesh.neutral,
        deltas,
        mesh.triangles,
        tuple(names),
        regions=mesh.regions,
        landmarks=mesh.landmarks,
        provenance=provenance,
        truth=truth,
    )


def _on_midline(shape: ShapeSpec, sites: Mapping[str, Site]) -> bool:
    """Whether every component of a shape moves a midline site (jaw, mouth, chin, nose tip)."""
    return all(sites[component.site].midline for component in shape.components)


def _stray_motion_pairs(
    deltas: np.ndarray, regions: Mapping[str, np.ndarray], planned: set[frozenset[int]]
) -> list[tuple[int, int]]:
    """Shape pairs other than the planned ones that come near being motion pairs (eqs. 11-12).

    Every shape whose active vertices touch exactly one sketch region is a candidate of that region
    (whatever share of them lies in it, and whether or not it has a mirror partner); a candidate pair of
    an upper and a lower region is near when ``cos(phi) < _STRAY_COSINE``. Checked at both ends and the
    middle of the paper's range of mu (sec. 5.2).
    """
    names = [name for pair in MOTION_REGION_PAIRS for name in pair]
    squared = np.einsum("knd,knd->kn", deltas, deltas)
    largest = squared.max(axis=1, keepdims=True)
    strays: set[tuple[int, int]] = set()
    for mu in _MU_RANGE:
        threshold = mu * mu * largest
        touched = np.column_stack([(squared[:, regions[name]] >= threshold).any(axis=1) for name in names])
        single = touched.sum(axis=1) == 1
        candidates = np.flatnonzero(single)
        masks = squared[candidates] >= threshold[candidates]
        summed = np.einsum("kn,knd->kd", masks.astype(float), deltas[candidates])
        direction = np.zeros((len(deltas), 3))
        direction[candidates] = summed / np.linalg.norm(summed, axis=1, keepdims=True)
        for column in range(0, len(names), 2):
            upper = np.flatnonzero(single & touched[:, column])
            lower = np.flatnonzero(single & touched[:, column + 1])
            rows, cols = np.nonzero(direction[upper] @ direction[lower].T < _STRAY_COSINE)
            strays.update(
                (int(upper[row]), int(lower[col]))
                for row, col in zip(rows, cols, strict=True)
                if frozenset((upper[row], lower[col])) not in planned
            )
    return sorted(strays)


def _preset(preset: str | PresetSpec) -> PresetSpec:
    if isinstance(preset, PresetSpec):
        return preset
    if isinstance(preset, str) and preset in PRESETS:
        return PRESETS[preset]
    raise HarnessError(f"unknown rig preset {preset!r}; choose one of: {', '.join(PRESETS)}")


def _evaluate(
    shape: ShapeSpec, mesh: FaceMesh, sites: Mapping[str, Site], rng: np.random.Generator, amplitude: float
) -> list[np.ndarray]:
    """The (N, 3) displacement field of each name of a catalogue entry (two for a mirror pair)."""
    midline = np.zeros((mesh.n_vertices, 3))
    left = np.zeros((mesh.n_vertices, 3))
    for component in shape.components:
        site = sites[component.site]
        target = midline if site.midline else left
        target += _component(mesh, site, component, JITTER[shape.jitter], rng, amplitude)
    if shape.is_pair:
        built = midline + left
        return [built, mesh.mirrored(built)]
    if shape.side == "L":
        return [midline + left]
    if shape.side == "R":
        return [mesh.mirrored(midline + left)]
    return [0.5 * (midline + mesh.mirrored(midline)) + (left + mesh.mirrored(left))]


def _component(
    mesh: FaceMesh,
    site: Site,
    component: Component,
    jitter: tuple[float, tuple[float, float], float, float],
    rng: np.random.Generator,
    amplitude: float,
) -> np.ndarray:
    """One component's (N, 3) displacement: site falloff (times its gate) times the motion.

    The same number of random draws is taken for every component, so the stream stays aligned.
    """
    shift, (smallest, largest), amplitude_jitter, degrees = jitter
    uniform = rng.uniform(-1.0, 1.0, 5)
    perpendicular = rng.standard_normal(3)

    center_x = 0.0 if site.midline else site.center[0] + shift * uniform[0]
    center_y = site.center[1] + shift * uniform[1]
    scale = smallest + (largest - smallest) * 0.5 * (1.0 + uniform[2])
    weight = _falloff(mesh, center_x, center_y, site.radii[0] * scale, site.radii[1] * scale, site.tilt)
    if site.gate is not None:
        weight *= mesh.gates[site.gate]
    size = site.amplitude * component.gain * amplitude * (1.0 + amplitude_jitter * uniform[3])

    motion = MOTIONS[component.motion]
    if motion.kind == "jaw":
        return _jaw_rotation(mesh, size * weight)
    if motion.kind == "normal":
        return (motion.vector[0] * size * weight)[:, None] * mesh.normals
    if motion.kind == "toward":
        inward = np.column_stack([center_x - mesh.neutral[:, 0], center_y - mesh.neutral[:, 1]])
        inward /= np.maximum(np.linalg.norm(inward, axis=1, keepdims=True), 1e-9)
        direction = np.column_stack([motion.vector[0] * inward, np.full(mesh.n_vertices, motion.vector[2])])
        return (size * weight)[:, None] * direction
    direction = _tilted(
        np.asarray(motion.vector, dtype=float), perpendicular, np.radians(degrees) * abs(uniform[4])
    )
    return (size * weight)[:, None] * direction[None, :]


def _falloff(mesh: FaceMesh, cx: float, cy: float, rx: float, ry: float, tilt: float) -> np.ndarray:
    """``(1 - q^4)^3`` for ``q < 1`` on the (tilted) ellipse around ``(cx, cy)``, exactly 0 outside.

    A plateau (a region moving together) with a C2 rim: at ``mu = 0.3`` (eq. 2) vertices with
    ``q < 0.76`` are active, ``0.76 <= q < 1`` smoothing and ``q >= 1`` static (Fig. 2).
    """
    dx = mesh.neutral[:, 0] - cx
    dy = mesh.neutral[:, 1] - cy
    if tilt:
        cos, sin = np.cos(tilt), np.sin(tilt)
        dx, dy = cos * dx + sin * dy, -sin * dx + cos * dy
    squared = (dx / rx) ** 2 + (dy / ry) ** 2
    inside = np.clip(1.0 - squared * squared, 0.0, None)
    return inside * inside * inside


def _tilted(vector: np.ndarray, random: np.ndarray, angle: float) -> np.ndarray:
    """``vector`` normalised and turned by ``angle`` toward the random direction ``random``."""
    unit = vector / np.linalg.norm(vector)
    perpendicular = random - (random @ unit) * unit
    length = np.linalg.norm(perpendicular)
    if length == 0.0:
        return unit
    return np.cos(angle) * unit + np.sin(angle) * perpendicular / length


def _jaw_rotation(mesh: FaceMesh, angles: np.ndarray) -> np.ndarray:
    """Rotation of each vertex about the jaw hinge (an ``x`` axis) by its own angle, as displacements."""
    hinge_y = mesh.layout.mouth_y + _JAW_HINGE[0]
    arm_y = mesh.neutral[:, 1] - hinge_y
    arm_z = mesh.neutral[:, 2] - _JAW_HINGE[1]
    cos, sin = np.cos(angles), np.sin(angles)
    displacement = np.zeros((mesh.n_vertices, 3))
    displacement[:, 1] = (cos - 1.0) * arm_y - sin * arm_z
    displacement[:, 2] = sin * arm_y + (cos - 1.0) * arm_z
    return displacement
