"""Catalogues of procedural blendshapes: facial sites, motions, and named shapes built from them.

A shape is a sum of *components*: a site of the face (an elliptic support around a point, optionally gated
to one side of the lip or eye line) moving in one way (a direction, along the normal, toward the mouth, or
a jaw rotation). Left-side sites (``x > 0``) give mirror pairs ``name_L``/``name_R``; midline sites give
self-symmetric shapes, or left/right pairs when they move sideways.

Motion symmetry (Carrigan et al. 2020, sec. 4.4.2) is planted on purpose: pairs of shapes confined to the
upper and lower lip (or to one eye's upper and lower lid) whose directions are exactly opposite. They are
never also mirror pairs, since a blendshape joins at most one symmetry pair: the lip pair is
self-symmetric, the eyelid pairs one-sided (the left eye's lids press together, the right eye's pull
apart). The other lip and lid shapes move at least 25 degrees away from opposite to every shape of the
partner region; the generator re-draws any random variant that still comes near.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass

from registry import HarnessError
from rigs._face_mesh import FaceLayout

#: Per-component random perturbation: centre shift (cm), radius scale range, relative amplitude, direction
#: (degrees). ``tight`` keeps planted motion pairs exactly opposite; ``broad`` (the site x motion extension)
#: and ``variant`` (numbered variants) are larger than the core shapes, like a big rig's combination shapes.
JITTER = {
    "tight": (0.05, (0.97, 1.03), 0.10, 0.0),
    "normal": (0.20, (0.92, 1.08), 0.15, 5.0),
    "broad": (0.20, (1.2, 1.5), 0.15, 5.0),
    "variant": (0.35, (1.3, 1.8), 0.25, 12.0),
}


@dataclass(frozen=True)
class Site:
    """Support of a component: an ellipse around ``center`` (``x >= 0``) with a ``(1 - q^4)^3`` falloff.

    ``gate`` names a `FaceMesh` gate (``above_mouth`` ...) that confines the site to one side of a line.
    ``amplitude`` is the site's typical displacement in centimetres.
    """

    center: tuple[float, float]
    radii: tuple[float, float]
    amplitude: float
    tilt: float = 0.0
    gate: str | None = None

    @property
    def midline(self) -> bool:
        return self.center[0] == 0.0


@dataclass(frozen=True)
class Motion:
    """How a component moves: ``kind`` is ``move`` (along ``vector``, lateral ``+x`` on the left side),
    ``normal`` (along the surface normal, ``vector[0]`` is the sign), ``toward`` (in the image plane
    toward the site centre with weight ``vector[0]`` plus ``vector[2]`` forward) or ``jaw`` (rotation
    about the jaw hinge by ``amplitude`` radians)."""

    kind: str
    vector: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Component:
    """A site moving by a motion, with ``gain`` times the site's amplitude."""

    site: str
    motion: str
    gain: float = 1.0


@dataclass(frozen=True)
class ShapeSpec:
    """One catalogue entry: a mirror pair (left name, right name), a self-symmetric shape (one name,
    ``side=None``) or a one-sided shape with no mirror partner (one name, ``side`` ``"L"`` or ``"R"``; an
    ``R`` shape is built on the left and mirrored).

    ``jitter`` selects a `JITTER` level; ``varies`` says whether numbered variants may be derived from it
    (not for shapes confined to a sketch region, whose directions are planned).
    """

    names: tuple[str, ...]
    components: tuple[Component, ...]
    jitter: str = "normal"
    varies: bool = True
    side: str | None = None

    @property
    def is_pair(self) -> bool:
        return len(self.names) == 2

    @property
    def self_symmetric(self) -> bool:
        return len(self.names) == 1 and self.side is None


@dataclass(frozen=True)
class Catalogue:
    """Shapes in priority order (extended by numbered variants, see `select`) and the planted motion
    pairs (upper, lower) among them."""

    shapes: tuple[ShapeSpec, ...]
    motion_pairs: tuple[tuple[str, str], ...]


MOTIONS: dict[str, Motion] = {
    "up": Motion("move", (0.0, 1.0, 0.15)),
    "down": Motion("move", (0.0, -1.0, -0.1)),
    "in": Motion("move", (-1.0, 0.05, 0.05)),
    "out": Motion("move", (1.0, 0.0, -0.15)),
    "forward": Motion("move", (0.0, -0.1, 1.0)),
    "back": Motion("move", (0.0, 0.05, -1.0)),
    "left": Motion("move", (1.0, 0.0, -0.05)),
    "puff": Motion("normal", (1.0, 0.0, 0.0)),
    "suck": Motion("normal", (-1.0, 0.0, 0.0)),
    "pucker": Motion("toward", (0.7, 0.0, 0.7)),
    "funnel": Motion("toward", (-0.6, 0.0, 0.8)),
    "jawOpen": Motion("jaw"),
    "sneer": Motion("move", (0.15, 1.0, 0.25)),
    "flare": Motion("move", (1.0, 0.0, 0.2)),
    "smile": Motion("move", (0.55, 0.8, -0.25)),
    "smileWide": Motion("move", (0.85, 0.5, -0.3)),
    "smileNarrow": Motion("move", (0.3, 0.95, 0.05)),
    "smileSubtle": Motion("move", (0.5, 0.75, -0.1)),
    "frown": Motion("move", (0.15, -1.0, -0.1)),
    "stretch": Motion("move", (1.0, -0.3, -0.2)),
    "dimple": Motion("move", (0.35, 0.1, -1.0)),
    # Eyelids (planned so that only the one-sided lid pairs are opposite, exactly).
    "blink": Motion("move", (0.0, -1.0, 0.45)),
    "wide": Motion("move", (0.0, 1.0, 0.3)),
    "squint": Motion("move", (0.45, 1.0, 0.6)),
    "lidLower": Motion("move", (0.3, -1.0, 0.35)),
    "upperLidPress": Motion("move", (0.6, -0.8, -0.3)),
    "lowerLidPress": Motion("move", (-0.6, 0.8, 0.3)),
    "upperLidPull": Motion("move", (0.6, 0.8, -0.3)),
    "lowerLidPull": Motion("move", (-0.6, -0.8, 0.3)),
    # Lips (planned likewise: only the midline raise/depress pair is opposite).
    "lipRaise": Motion("move", (0.0, 0.97, -0.25)),
    "lipDepress": Motion("move", (0.0, -0.97, 0.25)),
    "lipRaiseSide": Motion("move", (0.45, 0.8, 0.4)),
    "lipDepressSide": Motion("move", (0.45, -0.8, 0.4)),
    "rollUpper": Motion("move", (0.0, -1.0, -0.6)),
    "rollLower": Motion("move", (0.0, 1.0, -0.6)),
    "shrugUpper": Motion("move", (0.0, -0.3, 1.0)),
    "shrugLower": Motion("move", (0.0, 0.1, 1.0)),
    "pressUpper": Motion("move", (0.0, -1.0, -0.1)),
    "pressLower": Motion("move", (0.0, 1.0, -0.1)),
}


def face_sites(layout: FaceLayout) -> dict[str, Site]:
    """The facial sites of a layout (left side and midline), placed relative to its features."""
    ex, ey, ew, eo = layout.eye_x, layout.eye_y, layout.eye_half_width, layout.eye_opening
    my, mw, tip = layout.mouth_y, layout.mouth_half_width, layout.nose_tip_y
    return {
        # forehead and brows
        "brow_inner": Site((0.45 * ex, ey + 2.3), (2.0, 1.2), 0.7),
        "brow_mid": Site((0.95 * ex, ey + 2.5), (2.1, 1.2), 0.7),
        "brow_outer": Site((ex + 1.5, ey + 2.2), (2.1, 1.2), 0.6, tilt=-0.3),
        "forehead_inner": Site((1.6, ey + 4.8), (2.8, 2.2), 0.5),
        "forehead_outer": Site((ex + 1.2, ey + 4.5), (2.8, 2.2), 0.5),
        "temple": Site((layout.half_width - 1.0, ey + 1.5), (1.6, 2.4), 0.35),
        "glabella": Site((0.0, ey + 1.7), (1.3, 1.3), 0.4),
        "forehead": Site((0.0, ey + 5.0), (4.0, 2.4), 0.6),
        # eyes
        "eye": Site((ex, ey), (1.15 * ew, 1.5), 0.25),
        "upper_lid": Site((ex, ey + eo + 0.05), (0.8 * ew, 0.62), 2.0 * eo, gate="above_eye"),
        "lower_lid": Site((ex, ey - eo - 0.1), (0.7 * ew, 0.55), 0.5, gate="below_eye"),
        "eye_outer": Site((ex + ew + 1.1, ey), (1.2, 1.8), 0.3),
        # cheeks
        "cheek_upper": Site((ex + 0.4, ey - 2.8), (2.2, 1.3), 0.5),
        "cheek": Site((ex + 1.0, ey - 3.4), (2.4, 2.1), 0.5),
        "cheek_lower": Site((mw + 2.2, my + 0.8), (2.1, 2.6), 0.6),
        "cheek_mass": Site((ex + 0.8, my + 2.6), (3.2, 3.6), 0.6),
        # nose
        "nose_bridge": Site((0.0, ey - 0.8), (1.0, 1.6), 0.25),
        "nose_side": Site((0.9, 0.5 * (ey + tip)), (0.9, 1.6), 0.25),
        "nose_wing": Site((1.25, tip - 0.5), (1.0, 1.1), 0.35),
        "nose_tip": Site((0.0, tip), (1.1, 1.0), 0.3),
        # mouth
        "nasolabial": Site((mw + 0.8, my + 1.5), (1.1, 2.0), 0.35, tilt=0.5),
        "lip_corner": Site((mw - 0.1, my), (1.7, 1.6), 0.6),
        "upper_lip_side": Site((0.5 * mw, my + 0.3), (0.78, 0.62), 0.4, gate="above_mouth"),
        "lower_lip_side": Site((0.5 * mw, my - 0.35), (0.78, 0.62), 0.4, gate="below_mouth"),
        "upper_lip": Site((0.0, my + 0.3), (0.62 * mw, 0.62), 0.4, gate="above_mouth"),
        "lower_lip": Site((0.0, my - 0.35), (0.62 * mw, 0.62), 0.4, gate="below_mouth"),
        "mouth": Site((0.0, my), (mw + 0.6, 1.6), 0.5),
        # chin and jaw
        "chin": Site((0.0, my - 3.3), (2.1, 1.9), 0.4),
        "chin_side": Site((2.0, my - 3.0), (1.7, 1.7), 0.35),
        "jaw_side": Site((layout.half_width - 2.1, my - 2.5), (2.3, 2.8), 0.4),
        "jaw": Site((0.0, my - 3.0), (7.5, 6.5), 0.22, gate="below_mouth"),
        "jaw_shift": Site((0.0, my - 3.0), (7.5, 6.5), 0.6, gate="below_mouth"),
    }


def _pair(stem: str, *components: Component, jitter: str = "normal", varies: bool = True) -> ShapeSpec:
    return ShapeSpec((f"{stem}_L", f"{stem}_R"), components, jitter, varies)


def _self(name: str, *components: Component, jitter: str = "normal", varies: bool = True) -> ShapeSpec:
    return ShapeSpec((name,), components, jitter, varies)


def _one_sided(name: str, side: str, *components: Component) -> ShapeSpec:
    return ShapeSpec((name,), components, "tight", False, side)


def _sides(
    left: str, right: str, *components: Component, jitter: str = "normal", varies: bool = True
) -> ShapeSpec:
    return ShapeSpec((left, right), components, jitter, varies)


C = Component


def _lid(site: str, motion: str) -> tuple[Component, Component]:
    """An eyelid motion with the faint drag of the skin around the eye (smoothing only, below mu)."""
    return C(site, motion), C("eye", motion, _SKIN_DRAG)


#: Gain of the skin drag: 0.3 x 0.25 cm, a fifth or less of the lid's own motion.
_SKIN_DRAG = 0.3

_EMOTIONS = (
    _self(
        "happy",
        C("lip_corner", "smile"),
        C("cheek", "up"),
        C("cheek_upper", "up", 0.6),
        C("eye_outer", "in", 0.5),
    ),
    _self("sad", C("brow_inner", "up"), C("lip_corner", "frown"), C("chin", "up", 0.6)),
    _self(
        "angry",
        C("brow_inner", "down"),
        C("brow_mid", "down", 0.7),
        C("nose_wing", "sneer", 0.6),
        C("mouth", "back", 0.4),
    ),
    _self(
        "surprise",
        C("brow_inner", "up"),
        C("brow_mid", "up"),
        C("brow_outer", "up"),
        C("jaw", "jawOpen", 0.5),
    ),
    _self(
        "disgust",
        C("nose_wing", "sneer"),
        C("nasolabial", "up"),
        C("brow_inner", "down", 0.5),
        C("chin", "up", 0.5),
    ),
    _self("fear", C("brow_inner", "up"), C("brow_mid", "in", 0.5), C("lip_corner", "stretch")),
)

_ONE_SIDED_LIDS = (
    _one_sided("eyeUpperLidPress_L", "L", *_lid("upper_lid", "upperLidPress")),
    _one_sided("eyeLowerLidPress_L", "L", *_lid("lower_lid", "lowerLidPress")),
    _one_sided("eyeUpperLidPull_R", "R", *_lid("upper_lid", "upperLidPull")),
    _one_sided("eyeLowerLidPull_R", "R", *_lid("lower_lid", "lowerLidPull")),
)

_FACS_CORE = (
    _pair("browInnerUp", C("brow_inner", "up")),
    _pair("browOuterUp", C("brow_outer", "up")),
    _pair("browDown", C("brow_mid", "down"), C("brow_inner", "in", 0.5)),
    _self("browInnerUp", C("brow_inner", "up")),
    _pair("eyeBlink", *_lid("upper_lid", "blink"), varies=False),
    _pair("eyeWide", *_lid("upper_lid", "wide"), varies=False),
    _pair("eyeSquint", *_lid("lower_lid", "squint"), varies=False),
    *_ONE_SIDED_LIDS,
    _pair("cheekRaise", C("cheek", "up")),
    _pair("cheekPuff", C("cheek_lower", "puff")),
    _self("cheekPuff", C("cheek_lower", "puff")),
    _pair("noseSneer", C("nose_wing", "sneer")),
    _pair("mouthSmile", C("lip_corner", "smile")),
    _pair("mouthSmileWide", C("lip_corner", "smileWide")),
    _pair("mouthSmileNarrow", C("lip_corner", "smileNarrow")),
    _pair("mouthFrown", C("lip_corner", "frown")),
    _pair("mouthStretch", C("lip_corner", "stretch")),
    _pair("mouthDimple", C("lip_corner", "dimple")),
    _pair("mouthPress", C("upper_lip_side", "pressUpper"), C("lower_lip_side", "pressLower")),
    _pair("mouthUpperUp", C("upper_lip_side", "lipRaiseSide"), varies=False),
    _pair("mouthLowerDown", C("lower_lip_side", "lipDepressSide"), varies=False),
    _self("upperLipRaise", C("upper_lip", "lipRaise"), jitter="tight", varies=False),
    _self("lowerLipDepress", C("lower_lip", "lipDepress"), jitter="tight", varies=False),
    _sides("mouthLeft", "mouthRight", C("mouth", "left")),
    _self("mouthRollUpper", C("upper_lip", "rollUpper"), varies=False),
    _self("mouthRollLower", C("lower_lip", "rollLower"), varies=False),
    _self("mouthShrugUpper", C("upper_lip", "shrugUpper"), varies=False),
    _self("mouthShrugLower", C("lower_lip", "shrugLower"), varies=False),
    _self("mouthPucker", C("mouth", "pucker")),
    _self("mouthFunnel", C("mouth", "funnel")),
    _self("mouthClose", C("upper_lip", "pressUpper"), C("lower_lip", "pressLower")),
    _self("jawOpen", C("jaw", "jawOpen")),
    _self("jawForward", C("jaw_shift", "forward")),
    _sides("jawLeft", "jawRight", C("jaw_shift", "left")),
    _self("mouthSmile", C("lip_corner", "smile")),
    *_EMOTIONS[:2],
    _pair(
        "halfSmile",
        C("cheek_mass", "smile"),
        C("lip_corner", "smile", 0.5),
        C("eye_outer", "in", 0.8),
    ),
    *_EMOTIONS[2:4],
    _self("chinRaise", C("chin", "up")),
    _pair("eyeLookUp", C("eye", "up")),
    _pair("eyeLookDown", C("eye", "down")),
    _pair("eyeLookIn", C("eye", "in")),
    _pair("eyeLookOut", C("eye", "out")),
    _pair("eyeLowerLidDown", *_lid("lower_lid", "lidLower"), varies=False),
    *_EMOTIONS[4:],
    _pair("noseFlare", C("nose_wing", "flare")),
    _pair("cheekSuck", C("cheek_lower", "suck")),
    _pair("browSqueeze", C("brow_inner", "in"), C("glabella", "down", 0.4)),
    _self("noseWrinkle", C("nose_bridge", "up"), C("nose_side", "up", 0.6)),
    _pair("halfFrown", C("cheek_mass", "down"), C("lip_corner", "frown", 0.5), C("brow_inner", "up", 0.8)),
    _self("foreheadRaise", C("forehead", "up")),
    _pair("mouthSmileSubtle", C("lip_corner", "smileSubtle", 0.6)),
    _pair("eyeCrowsFeet", C("eye_outer", "in")),
    _self("tongueOut", C("mouth", "forward"), C("lower_lip", "lipDepress", 0.3)),
)

_FACS_MOTION_PAIRS = (
    ("upperLipRaise", "lowerLipDepress"),
    ("eyeUpperLidPress_L", "eyeLowerLidPress_L"),
    ("eyeUpperLidPull_R", "eyeLowerLidPull_R"),
)

#: Further site x motion shapes after the core, named ``<site><Motion>_L`` (midline: without suffix).
_EXTENSION_MOTIONS = {
    "brow_inner": ("down", "forward"),
    "brow_mid": ("up", "in", "forward"),
    "brow_outer": ("down", "in", "out"),
    "forehead_inner": ("up", "down", "in"),
    "forehead_outer": ("up", "down", "out"),
    "temple": ("up", "back", "forward"),
    "eye_outer": ("up", "down", "back"),
    "cheek_upper": ("up", "out", "forward"),
    "cheek": ("down", "out", "in", "back"),
    "cheek_lower": ("up", "down", "out", "in"),
    "nose_side": ("up", "down", "out"),
    "nose_wing": ("down", "in", "forward"),
    "nasolabial": ("up", "out", "in", "back"),
    "lip_corner": ("in", "forward", "back"),
    "chin_side": ("up", "down", "out", "in"),
    "jaw_side": ("up", "out", "in", "back"),
    "glabella": ("up", "down", "forward"),
    "forehead": ("down", "forward"),
    "nose_bridge": ("down", "forward"),
    "nose_tip": ("up", "down", "forward", "left"),
    "chin": ("down", "forward", "back", "left"),
    "mouth": ("up", "down", "forward", "back"),
}


def _camel(site: str) -> str:
    head, *rest = site.split("_")
    return head + "".join(part.capitalize() for part in rest)


def _extension(sites: dict[str, Site]) -> tuple[ShapeSpec, ...]:
    shapes = []
    for site, motions in _EXTENSION_MOTIONS.items():
        for motion in motions:
            stem = _camel(site) + motion.capitalize()
            component = C(site, motion)
            if not sites[site].midline:
                shapes.append(_pair(stem, component, jitter="broad"))
            elif MOTIONS[motion].vector[0] != 0.0 and MOTIONS[motion].kind == "move":
                shapes.append(_sides(stem, _camel(site) + "Right", component, jitter="broad"))
            else:
                shapes.append(_self(stem, component, jitter="broad"))
    return tuple(shapes)


_ARKIT = (
    _sides("eyeBlinkLeft", "eyeBlinkRight", *_lid("upper_lid", "blink"), varies=False),
    _sides("eyeLookDownLeft", "eyeLookDownRight", C("eye", "down")),
    _sides("eyeLookInLeft", "eyeLookInRight", C("eye", "in")),
    _sides("eyeLookOutLeft", "eyeLookOutRight", C("eye", "out")),
    _sides("eyeLookUpLeft", "eyeLookUpRight", C("eye", "up")),
    _sides("eyeSquintLeft", "eyeSquintRight", *_lid("lower_lid", "squint"), varies=False),
    _sides("eyeWideLeft", "eyeWideRight", *_lid("upper_lid", "wide"), varies=False),
    _self("jawForward", C("jaw_shift", "forward")),
    _sides("jawLeft", "jawRight", C("jaw_shift", "left")),
    _self("jawOpen", C("jaw", "jawOpen")),
    _self("mouthClose", C("upper_lip", "pressUpper"), C("lower_lip", "pressLower")),
    _self("mouthFunnel", C("mouth", "funnel")),
    _self("mouthPucker", C("mouth", "pucker")),
    _sides("mouthLeft", "mouthRight", C("mouth", "left")),
    _sides("mouthSmileLeft", "mouthSmileRight", C("lip_corner", "smile")),
    _sides("mouthFrownLeft", "mouthFrownRight", C("lip_corner", "frown")),
    _sides("mouthDimpleLeft", "mouthDimpleRight", C("lip_corner", "dimple")),
    _sides("mouthStretchLeft", "mouthStretchRight", C("lip_corner", "stretch")),
    _self("mouthRollLower", C("lower_lip", "rollLower"), varies=False),
    _self("mouthRollUpper", C("upper_lip", "rollUpper"), varies=False),
    _self("mouthShrugLower", C("lower_lip", "shrugLower"), varies=False),
    _self("mouthShrugUpper", C("upper_lip", "shrugUpper"), varies=False),
    _sides(
        "mouthPressLeft",
        "mouthPressRight",
        C("upper_lip_side", "pressUpper"),
        C("lower_lip_side", "pressLower"),
    ),
    _sides("mouthLowerDownLeft", "mouthLowerDownRight", C("lower_lip_side", "lipDepressSide"), varies=False),
    _sides("mouthUpperUpLeft", "mouthUpperUpRight", C("upper_lip_side", "lipRaiseSide"), varies=False),
    _sides("browDownLeft", "browDownRight", C("brow_mid", "down"), C("brow_inner", "in", 0.5)),
    _self("browInnerUp", C("brow_inner", "up")),
    _sides("browOuterUpLeft", "browOuterUpRight", C("brow_outer", "up")),
    _self("cheekPuff", C("cheek_lower", "puff")),
    _sides("cheekSquintLeft", "cheekSquintRight", C("cheek_upper", "up")),
    _sides("noseSneerLeft", "noseSneerRight", C("nose_wing", "sneer")),
    _self("tongueOut", C("mouth", "forward"), C("lower_lip", "lipDepress", 0.3)),
)

_TINY = (
    _pair("browInnerUp", C("brow_inner", "up")),
    _pair("eyeBlink", *_lid("upper_lid", "blink"), varies=False),
    _self("jawOpen", C("jaw", "jawOpen")),
    _self("mouthFunnel", C("mouth", "funnel")),
    _self("upperLipRaise", C("upper_lip", "lipRaise"), jitter="tight", varies=False),
    _self("lowerLipDepress", C("lower_lip", "lipDepress"), jitter="tight", varies=False),
    *_ONE_SIDED_LIDS,
)


def catalogue(name: str, layout: FaceLayout) -> Catalogue:
    """The named catalogue (``facs``, ``arkit52`` or ``tiny``) for a face layout."""
    if name == "facs":
        return Catalogue(_FACS_CORE + _extension(face_sites(layout)), _FACS_MOTION_PAIRS)
    if name == "arkit52":
        return Catalogue(_ARKIT, ())
    if name == "tiny":
        return Catalogue(_TINY, _FACS_MOTION_PAIRS)
    raise HarnessError(f"unknown shape catalogue {name!r}; choose one of: arkit52, facs, tiny")


def variant_name(name: str, number: int) -> str:
    """``mouthSmile_L`` -> ``mouthSmile2_L``; ``jawLeft`` -> ``jawLeft2``."""
    for suffix in ("_L", "_R"):
        if name.endswith(suffix):
            return f"{name[: -len(suffix)]}{number}{suffix}"
    return f"{name}{number}"


def select(shapes: Sequence[ShapeSpec], n_shapes: int) -> list[ShapeSpec]:
    """The first entries of ``shapes``, then numbered variants of the varying ones, totalling exactly
    ``n_shapes`` blendshapes; a pair that no longer fits is skipped for a later single."""
    chosen: list[ShapeSpec] = []
    remaining = n_shapes
    for spec in _stream(shapes):
        if remaining == 0:
            break
        if len(spec.names) <= remaining:
            chosen.append(spec)
            remaining -= len(spec.names)
    return chosen


def _stream(shapes: Sequence[ShapeSpec]) -> Iterator[ShapeSpec]:
    yield from shapes
    varying = [spec for spec in shapes if spec.varies]
    if not any(spec.self_symmetric for spec in varying):
        raise ValueError("catalogue has no varying self-symmetric shape to extend it with")
    number = 2
    while True:
        for spec in varying:
            names = tuple(variant_name(name, number) for name in spec.names)
            yield ShapeSpec(names, spec.components, "variant", True, spec.side)
        number += 1
