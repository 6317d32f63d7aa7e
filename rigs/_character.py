"""Character-specific targets: blendshapes that move unlike the warped template.

A warp (`rigs._warp`) makes the target from the template by one smooth map of space, so every target shape
is what deformation transfer predicts from the two neutrals, up to its own approximation error: training
expressions then have little to teach (Carrigan et al. 2020, sec. 5.1 evaluate exactly this). A real actor
moves differently from the template in ways no neutral reveals. `Character` adds such differences to the
blendshapes of a rig, with known ground truth:

- **Amplitude by region.** Each shape gets its own smooth gain field: a log-gain per face region (upper,
  middle and lower face, each on the left and on the right), blended across region borders.
- **Direction by region.** Each shape's displacements turn about a shape-specific axis by an angle that
  varies by region in the same way.
- **Asymmetry.** The actor's whole left side moves more (or less) than the right one, and every
  left/right-named shape draws its own gains, so mirror twins stop being mirror images.
- **Identity-specific motion.** Actor traits applied by shape name: a wider smile (the lateral motion of
  every ``smile`` shape is stretched), a heavier jaw (every ``jaw`` and ``mouthOpen`` shape moves more) and
  a stiffer brow (every ``brow`` shape moves less).

Only displacements change: the neutral, the triangles and the names stay, and a vertex that does not move
in a shape still does not (every change multiplies or turns a displacement). A shape whose changed mesh
would fold (a triangle turning by more than 75 degrees) gets its changes halved until it does not.
Everything is drawn from ``numpy.random.default_rng`` seeded by the step's seed, the rig's generator
preset and seed (``rig.provenance.generator``) and each shape's name, so the same rig and step give the
same target bit for bit, whatever the order of the shapes.
"""

from __future__ import annotations

import zlib
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from registry import HarnessError
from rigs._face_mesh import LANDMARK_REGIONS, region_centre
from rigs._provenance import CharacterRecord, GeneratorSettings, ShapeChange
from rigs._rig import Rig, RigError

#: Face regions of the gain and angle fields: three bands from brow to chin, each on both sides.
REGIONS: tuple[str, ...] = ("upper_L", "upper_R", "middle_L", "middle_R", "lower_L", "lower_R")
#: Spread of the per-region log-gain of each shape at strength 1 (exp(0.2) = 1.22).
GAIN_SPREAD = 0.2
#: Spread of the per-region turn of each shape's displacements at strength 1, in degrees.
ANGLE_SPREAD = 12.0
#: Actor traits at strength 1, drawn uniformly from these ranges (see the module documentation).
TRAIT_RANGES: Mapping[str, tuple[float, float]] = {
    "asymmetry": (0.06, 0.12),
    "smile_width": (1.2, 1.4),
    "jaw_weight": (1.15, 1.3),
    "brow_range": (0.7, 0.85),
}
#: Width of the blend between regions, as a fraction of the bounding-box diagonal: bands and sides.
_BAND_BLEND, _SIDE_BLEND = 0.03, 0.015
#: A shape whose changed mesh would turn a triangle by more than this many degrees (against the shape it
#: was) has its changes damped by the next factor of `_DAMPING`, so no target shape folds.
_MAX_TURN = 75.0
_DAMPING = (1.0, 0.5, 0.25, 0.125, 0.0)
#: Strength is a multiplier of every change; beyond this the turned and scaled shapes stop being plausible.
STRENGTH_RANGE = (0.0, 3.0)


def _number(label: str, value: Any) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise HarnessError(f"character {label} must be a number, got {value!r}") from None
    if not np.isfinite(number):
        raise HarnessError(f"character {label} must be finite, got {value!r}")
    return number


@dataclass(frozen=True)
class Character:
    """A character-specific variant of a rig's blendshapes (see the module documentation).

    Parameters
    ----------
    strength : float in STRENGTH_RANGE, default 1
        Multiplier of every change: 0 leaves the rig as it is; 1 gives region gains of about
        ``exp(+-0.2)``, turns of about 12 degrees and the `TRAIT_RANGES`.
    seed : int >= 0, default 0
        Seeds the actor (traits) and each shape's draws, together with the rig's preset, generator seed
        and the shape's name.

    Examples
    --------
    >>> import rigs
    >>> target = rigs.warp(rigs.generate("tiny"), "alien+character")
    >>> sorted(target.provenance.character.traits)
    ['asymmetry', 'brow_range', 'jaw_weight', 'smile_width']
    """

    strength: float = 1.0
    seed: int = 0

    def __post_init__(self) -> None:
        strength = _number("strength", self.strength)
        low, high = STRENGTH_RANGE
        if not low <= strength <= high:
            raise HarnessError(f"character strength must lie in [{low:g}, {high:g}], got {self.strength!r}")
        object.__setattr__(self, "strength", strength)
        seed = _number("seed", self.seed)
        if seed < 0 or seed != int(seed):
            raise HarnessError(f"character seed must be a non-negative integer, got {self.seed!r}")
        object.__setattr__(self, "seed", int(seed))

    def resolve(self, rig: Rig) -> list[Any]:
        """No point-map primitive: a character changes blendshapes, not space (see `apply`)."""
        return []

    def describe(self) -> dict[str, Any]:
        return {"kind": "character", "strength": self.strength, "seed": self.seed}

    def label(self) -> str:
        if self.strength == 1.0 and self.seed == 0:
            return "character"
        return f"character:{self.strength:g},{self.seed}"

    def apply(self, rig: Rig) -> Rig:
        """The rig with character-specific blendshapes (neutral, triangles, names and regions kept).

        Returns
        -------
        Rig
            ``provenance.character`` (`rigs.CharacterRecord`) holds the parameters, the actor's
            ``traits``, the ``regions`` and per shape the changes applied (`rigs.ShapeChange`):
            ``log_gains`` and ``angles`` (degrees, one per region), the turning ``axis``, the per-axis
            trait ``scale`` and the ``damping`` (1 unless the full change would fold a triangle): the
            ground truth of how the target differs.

        Raises
        ------
        RigError
            For a rig without triangles (the surface normals of the regions need them).
        """
        if rig.n_triangles == 0:
            raise RigError(f"{rig.provenance.label}: a character variant needs a triangle mesh")
        generator = rig.provenance.generator or GeneratorSettings(preset="", seed=0)  # (not generated)
        base = [self.seed, _crc(generator.preset), generator.seed]
        traits = _traits(np.random.default_rng([*base, _crc("traits")]), self.strength)
        weights = region_weights(rig)
        deltas = np.array(rig.deltas, dtype=np.float64, copy=True)
        shapes: dict[str, ShapeChange] = {}
        side = np.array(
            [traits["asymmetry"] if name.endswith("_L") else -traits["asymmetry"] for name in REGIONS]
        )
        for k, name in enumerate(rig.names):
            rng = np.random.default_rng([*base, _crc(name)])
            log_gains = side + rng.normal(0.0, GAIN_SPREAD * self.strength, len(REGIONS))
            angles = rng.normal(0.0, ANGLE_SPREAD * self.strength, len(REGIONS))
            axis = rng.standard_normal(3)
            axis /= np.linalg.norm(axis)
            scale = _trait_scale(name, traits)
            moving = np.flatnonzero(np.any(deltas[k] != 0.0, axis=1))
            damping = 1.0
            if moving.size:
                for damping in _DAMPING:  # the first that folds no triangle
                    changed = _changed(
                        deltas[k, moving], weights[moving], damping, log_gains, angles, axis, scale
                    )
                    if _keeps_orientation(rig, k, moving, changed):
                        break
                deltas[k, moving] = changed
            shapes[name] = ShapeChange(
                damping=damping,
                log_gains=tuple(float(damping * value) for value in log_gains),
                angles=tuple(float(damping * value) for value in angles),
                axis=(float(axis[0]), float(axis[1]), float(axis[2])),
                scale=tuple(float(1.0 + damping * (value - 1.0)) for value in scale),
            )
        provenance = replace(
            rig.provenance,
            source=f"{rig.provenance.label} with {self.label()}",
            character=CharacterRecord(self.strength, self.seed, traits, REGIONS, shapes),
        )
        return replace(rig, deltas=deltas, provenance=provenance)


def region_weights(rig: Rig) -> np.ndarray:
    """(N, 6) smooth partition of unity over `REGIONS` on the rig's neutral.

    The band borders lie halfway between the eyes and the nose and halfway between the nose and the
    mouth, located like the warps' centres (landmarks, else the regions' centroids); a rig without them
    is cut into thirds of its height. Left is ``x`` above the bounding box's centre.
    """
    low, high = rig.bounding_box()
    diagonal = rig.diagonal() or 1.0
    x, y = rig.neutral[:, 0], rig.neutral[:, 1]
    heights = {name: _landmark_height(rig, name) for name in ("eye_L", "eye_R", "nose", "mouth")}
    if all(value is not None for value in heights.values()):
        eyes = 0.5 * (heights["eye_L"] + heights["eye_R"])
        upper_border, lower_border = (
            0.5 * (eyes + heights["nose"]),
            0.5 * (heights["nose"] + heights["mouth"]),
        )
    else:
        upper_border = low[1] + (high[1] - low[1]) * 2.0 / 3.0
        lower_border = low[1] + (high[1] - low[1]) / 3.0
    width = _BAND_BLEND * diagonal
    upper = _logistic((y - upper_border) / width)
    lower = _logistic((lower_border - y) / width)
    middle = np.clip(1.0 - upper - lower, 0.0, None)
    bands = np.column_stack([upper, middle, lower])
    bands /= bands.sum(axis=1, keepdims=True)
    left = _logistic((x - 0.5 * (low[0] + high[0])) / (_SIDE_BLEND * diagonal))
    sides = np.column_stack([left, 1.0 - left])
    return (bands[:, :, None] * sides[:, None, :]).reshape(len(x), len(REGIONS))


def _landmark_height(rig: Rig, name: str) -> float | None:
    """Height (``y``) of a landmark: ``rig.landmarks``, else the centroid of its regions
    (`rigs._face_mesh.LANDMARK_REGIONS`, as the warps locate centres), else None."""
    if name in rig.landmarks:
        return rig.landmarks[name][1]
    regions = LANDMARK_REGIONS[name]
    if all(region in rig.regions and len(rig.regions[region]) for region in regions):
        return float(region_centre(rig.neutral, rig.regions, regions)[1])
    return None


def _traits(rng: np.random.Generator, strength: float) -> dict[str, float]:
    """The actor's traits, scaled by ``strength`` (the asymmetry's sign is drawn too)."""
    drawn = {name: float(rng.uniform(*bounds)) for name, bounds in TRAIT_RANGES.items()}
    sign = 1.0 if rng.uniform() < 0.5 else -1.0
    traits = {"asymmetry": sign * drawn["asymmetry"] * strength}
    for name in ("smile_width", "jaw_weight", "brow_range"):
        traits[name] = 1.0 + strength * (drawn[name] - 1.0)
    return traits


def _changed(
    deltas: np.ndarray,
    weights: np.ndarray,
    damping: float,
    log_gains: np.ndarray,
    angles: np.ndarray,
    axis: np.ndarray,
    scale: np.ndarray,
) -> np.ndarray:
    """A shape's moving displacements gained, turned and scaled, every change times ``damping``."""
    gained = deltas * np.exp(weights @ (damping * log_gains))[:, None]
    turned = _rotated(gained, axis, np.radians(weights @ (damping * angles)))
    return turned * (1.0 + damping * (scale - 1.0))


def _keeps_orientation(rig: Rig, k: int, moving: np.ndarray, changed: np.ndarray) -> bool:
    """Whether no triangle of shape ``k`` turns by more than `_MAX_TURN` against the original shape."""
    touched = np.isin(rig.triangles, moving).any(axis=1)
    triangles = rig.triangles[touched]
    before = rig.neutral + rig.deltas[k]
    after = before.copy()
    after[moving] = rig.neutral[moving] + changed
    a, b = (_normals(points, triangles) for points in (before, after))
    lengths = np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1)
    cosine = np.einsum("ij,ij->i", a, b) / np.where(lengths > 0, lengths, 1.0)
    return bool(np.all(cosine[lengths > 0] >= np.cos(np.radians(_MAX_TURN))))


def _normals(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    a, b, c = (points[triangles[:, i]] for i in range(3))
    return np.cross(b - a, c - a)


def _trait_scale(name: str, traits: Mapping[str, float]) -> np.ndarray:
    """Per-axis factor of a shape's displacements from the actor's traits, chosen by its name."""
    lowered = name.lower()
    scale = np.ones(3)
    if "smile" in lowered:
        scale[0] *= traits["smile_width"]
    if lowered.startswith("jaw") or "mouthopen" in lowered:
        scale *= traits["jaw_weight"]
    if "brow" in lowered:
        scale *= traits["brow_range"]
    return scale


def _rotated(vectors: np.ndarray, axis: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Each vector turned about the unit ``axis`` by its own angle (Rodrigues' formula)."""
    cos, sin = np.cos(angles)[:, None], np.sin(angles)[:, None]
    along = (vectors @ axis)[:, None] * axis
    return vectors * cos + np.cross(axis, vectors) * sin + along * (1.0 - cos)


def _logistic(t: np.ndarray) -> np.ndarray:
    return 0.5 * (1.0 + np.tanh(0.5 * t))


def _crc(text: str) -> int:
    return zlib.crc32(text.encode())
