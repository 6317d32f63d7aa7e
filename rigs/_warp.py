"""Warps: smooth invertible deformations that turn a rig into a hard target character (Carrigan et al.
2020, sec. 5.1).

The paper makes test targets by deforming every mesh of a rig: non-uniform scaling, and free-form local
enlarging or shrinking of the eyes, mouth or nose. `warp` applies such a map ``f`` to the neutral and to
every blendshape, so the target's deltas are ``f(v_0 + dv_k) - f(v_0)``: same topology, semantically the
same blendshapes, known ground truth. Static vertices stay static (their deltas stay exactly 0).

Spec forms accepted by `warp`
-----------------------------
- a `WARPS` preset name: ``"big-eyes"``, ``"scale-x1.3"``, ``"alien"`` ...;
- a string of steps joined by ``+``, each a preset name, ``scale:SX,SY,SZ``,
  ``local:CENTER,FACTOR[,RADIUS]`` with CENTER a name or ``[x;y;z]`` and RADIUS in rig units or, with a
  ``d`` suffix, as a fraction of the bounding-box diagonal (``"scale:1.3,1,1+local:mouth,0.7,0.1d"``), or
  ``character:STRENGTH[,SEED]`` (see below);
- a dict: ``{"kind": "scale", "factors": [1.3, 1, 1]}``,
  ``{"kind": "local", "center": "mouth" or [x, y, z], "factor": 0.7, "radius": 2.0}`` (or
  ``"radius_rel"``, a fraction of the bounding-box diagonal), ``{"kind": "character", "strength": 1.0,
  "seed": 0}``, ``{"kind": "compose", "steps": [...]}``;
- a list or tuple of any of these (applied in order);
- a `Scale`, `LocalScale`, `Character` or `Compose` object.

Named centres (``eye_L``, ``eye_R``, ``eyes`` = both, ``mouth``, ``nose``, or any landmark/region name) come
from ``rig.landmarks`` when present, else from the centroid of the rig's regions (eyelids for an
eye, lips for the mouth, a ``nose`` region for the nose), else from a region with the centre's name.

Character-specific targets
--------------------------
A warp alone gives a target whose shapes deformation transfer predicts from the two neutrals. The step
``character`` (`rigs._character.Character`; ``character:STRENGTH[,SEED]`` or
``{"kind": "character", "strength": 1.0, "seed": 0}``) changes the blendshapes themselves, as an actor
moves unlike the template: per-shape gains and turns by face region, asymmetry, a wider smile, a heavier
jaw. It changes no point of space, so it applies after every geometric step of the spec, wherever it
stands in it. Every preset ``NAME`` of `WARPS` has its character variant ``NAME+character`` (e.g.
``alien+character``, the paper's cases made character-specific), and ``character`` alone keeps the
template's geometry.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from registry import HarnessError
from rigs._character import Character
from rigs._face_mesh import LANDMARK_REGIONS, region_centre
from rigs._provenance import WarpRecord
from rigs._rig import Rig, RigError

#: Local factors keep the radial stretch ``1 + (f - 1)(g + t g')`` >= 0.35 and the map invertible
#: (it is invertible for ``0 < f < 2.53`` with ``g = (1 - t^2)^3``, whose ``g + t g'`` lies in [-0.653, 1]).
FACTOR_RANGE = (0.35, 2.0)
#: Default support radii as fractions of the bounding-box diagonal; the eyes' stay below half the distance
#: between the eyes of the generated faces, so left and right supports never meet.
_DEFAULT_RADIUS_REL = {"eye_L": 0.11, "eye_R": 0.11, "mouth": 0.12, "nose": 0.10}


def _positive(label: str, value: Any) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise HarnessError(f"{label} must be a positive number, got {value!r}") from None
    if not np.isfinite(number) or number <= 0.0:
        raise HarnessError(f"{label} must be a positive number, got {value!r}")
    return number


@dataclass(frozen=True, eq=False)
class AxisScale:
    """``p -> c + (p - c) * factors``."""

    center: np.ndarray
    factors: np.ndarray

    def __call__(self, points: np.ndarray) -> np.ndarray:
        return self.center + (points - self.center) * self.factors


@dataclass(frozen=True, eq=False)
class RadialScale:
    """``p -> c + (p - c) (1 + (factor - 1) g(|p - c| / radius))``, ``g(t) = (1 - t^2)^3`` inside the ball.

    Only polynomial operations, so equal inputs give equal outputs wherever they sit in an array; points
    outside the ball are returned unchanged, bit for bit.
    """

    center: np.ndarray
    radius: float
    factor: float

    def __call__(self, points: np.ndarray) -> np.ndarray:
        offset = points - self.center
        squared = np.einsum("...i,...i->...", offset, offset) / (self.radius * self.radius)
        inside = np.clip(1.0 - squared, 0.0, None)[..., None]
        moved = self.center + offset * (1.0 + (self.factor - 1.0) * inside * inside * inside)
        return np.where(inside > 0.0, moved, points)


Primitive = AxisScale | RadialScale


@dataclass(frozen=True)
class Scale:
    """Non-uniform scale by per-axis ``factors`` about the centre of the neutral's bounding box."""

    factors: tuple[float, float, float]

    def __post_init__(self) -> None:
        if (
            not isinstance(self.factors, Sequence | np.ndarray)
            or isinstance(self.factors, str)
            or len(self.factors) != 3
        ):
            raise HarnessError(f"scale factors must be three positive numbers, got {self.factors!r}")
        factors = tuple(_positive("scale factor", value) for value in self.factors)
        object.__setattr__(self, "factors", factors)

    def resolve(self, rig: Rig) -> list[Primitive]:
        """One `AxisScale` about the bounding-box centre of ``rig``'s neutral."""
        low, high = rig.bounding_box()
        return [AxisScale(0.5 * (low + high), np.asarray(self.factors))]

    def describe(self) -> dict[str, Any]:
        return {"kind": "scale", "factors": list(self.factors)}

    def label(self) -> str:
        return "scale:" + ",".join(f"{value:g}" for value in self.factors)


@dataclass(frozen=True)
class LocalScale:
    """Free-form local enlarge (``factor > 1``) or shrink (``factor < 1``) around a centre.

    ``p -> c + (p - c) (1 + (factor - 1) g(|p - c| / radius))`` with ``g(t) = (1 - t^2)^3`` for ``t < 1``
    and 0 beyond: the identity outside the ball, C2 across its rim, radially monotone (so invertible
    and orientation preserving) for factors in `FACTOR_RANGE`.

    Parameters
    ----------
    center : str or (3,) floats
        A named centre (``eye_L``, ``eye_R``, ``eyes``, ``mouth``, ``nose``, or a landmark/region name) or
        coordinates.
    factor : float in FACTOR_RANGE
        Scale at the centre.
    radius : float, optional
        Support radius in rig units.
    radius_rel : float, optional
        Support radius as a fraction of the neutral's bounding-box diagonal, used when ``radius`` is not
        given (default per centre: eyes 0.11, mouth 0.12, nose and others 0.10).
    """

    center: str | tuple[float, float, float]
    factor: float
    radius: float | None = None
    radius_rel: float | None = None

    def __post_init__(self) -> None:
        low, high = FACTOR_RANGE
        factor = _positive("local factor", self.factor)
        if not low <= factor <= high:
            raise HarnessError(
                f"local factor must lie in [{low}, {high}] to stay invertible, got {self.factor!r}"
            )
        object.__setattr__(self, "factor", factor)
        for label in ("radius", "radius_rel"):
            if getattr(self, label) is not None:
                object.__setattr__(self, label, _positive(f"local {label}", getattr(self, label)))
        if not isinstance(self.center, str):
            try:
                center = tuple(float(value) for value in self.center)
            except (TypeError, ValueError):
                center = ()
            if len(center) != 3 or not all(np.isfinite(center)):
                raise HarnessError(f"local center must be a name or three coordinates, got {self.center!r}")
            object.__setattr__(self, "center", center)

    def resolve(self, rig: Rig) -> list[Primitive]:
        """One `RadialScale` (two for ``eyes``) with its centre located on ``rig``."""
        if self.center == "eyes":
            return [*replace(self, center="eye_L").resolve(rig), *replace(self, center="eye_R").resolve(rig)]
        radius = self.radius
        if radius is None:
            default = _DEFAULT_RADIUS_REL.get(self.center, 0.10) if isinstance(self.center, str) else 0.10
            radius = (self.radius_rel or default) * rig.diagonal()
        return [RadialScale(locate(rig, self.center), float(radius), self.factor)]

    def describe(self) -> dict[str, Any]:
        center = self.center if isinstance(self.center, str) else list(self.center)
        described = {"kind": "local", "center": center, "factor": self.factor}
        if self.radius is not None:
            described["radius"] = self.radius
        if self.radius_rel is not None:
            described["radius_rel"] = self.radius_rel
        return described

    def label(self) -> str:
        center = (
            self.center
            if isinstance(self.center, str)
            else "[" + ";".join(f"{v:g}" for v in self.center) + "]"
        )
        if self.radius is not None:
            return f"local:{center},{self.factor:g},{self.radius:g}"
        if self.radius_rel is not None:
            return f"local:{center},{self.factor:g},{self.radius_rel:g}d"
        return f"local:{center},{self.factor:g}"


@dataclass(frozen=True)
class Compose:
    """Steps applied in order."""

    steps: tuple[Scale | LocalScale | Character | Compose, ...]

    def characters(self) -> list[Character]:
        """The character steps, in order (they apply after the geometry, see `warp`)."""
        return [
            character
            for step in self.steps
            for character in (step.characters() if isinstance(step, Compose) else [step])
            if isinstance(character, Character)
        ]

    def resolve(self, rig: Rig) -> list[Primitive]:
        """The primitives of all steps, in order, centres located on ``rig``."""
        return [primitive for step in self.steps for primitive in step.resolve(rig)]

    def describe(self) -> dict[str, Any]:
        return {"kind": "compose", "steps": [step.describe() for step in self.steps]}

    def label(self) -> str:
        return "+".join(step.label() for step in self.steps)


Warp = Scale | LocalScale | Character | Compose


def point_map(
    spec: str | Warp | Mapping[str, Any] | Sequence[Any], rig: Rig
) -> Callable[[np.ndarray], np.ndarray]:
    """The point map of a warp spec on ``rig``: its primitives in order, each centre located on ``rig`` and
    carried along by the primitives before it (so it stays on the same part of the face).

    Raises
    ------
    ValueError, RigError
        As `warp`.
    """
    carried: list[Primitive] = []
    for primitive in parse_warp(spec).resolve(rig):
        center = primitive.center
        for earlier in carried:
            center = earlier(center)
        carried.append(replace(primitive, center=center))

    def mapped(points: np.ndarray) -> np.ndarray:
        for primitive in carried:
            points = primitive(points)
        return points

    return mapped


_GEOMETRIC_WARPS: dict[str, Warp] = {
    "scale-x1.3": Scale((1.3, 1.0, 1.0)),
    "scale-x0.8": Scale((0.8, 1.0, 1.0)),
    "scale-y1.2": Scale((1.0, 1.2, 1.0)),
    "scale-z0.8": Scale((1.0, 1.0, 0.8)),
    "big-eyes": LocalScale("eyes", 1.4),
    "small-eyes": LocalScale("eyes", 0.75),
    "big-mouth": LocalScale("mouth", 1.3),
    "small-mouth": LocalScale("mouth", 0.7),
    "big-nose": LocalScale("nose", 1.35),
    "small-nose": LocalScale("nose", 0.75),
    "alien": Compose(
        (
            Scale((0.85, 1.15, 1.0)),
            LocalScale("eyes", 1.6),
            LocalScale("mouth", 0.65),
            LocalScale("nose", 0.7),
        )
    ),
}

#: Warp presets: the geometric ones, ``character`` alone, and ``NAME+character`` for every geometric one.
WARPS: Mapping[str, Warp] = {
    **_GEOMETRIC_WARPS,
    "character": Character(),
    **{f"{name}+character": Compose((step, Character())) for name, step in _GEOMETRIC_WARPS.items()},
}


def warp(rig: Rig, spec: str | Warp | Mapping[str, Any] | Sequence[Any]) -> Rig:
    """Warp every mesh of a rig: the target rig B of sec. 5.1 with ground-truth blendshapes.

    Parameters
    ----------
    rig : Rig
    spec : str, Warp, dict or list
        See the module documentation; e.g. ``"big-eyes"``, ``"scale:1.3,1,1+local:mouth,0.7"`` or
        ``{"kind": "local", "center": "mouth", "radius": 2.0, "factor": 0.7}``.

    Returns
    -------
    Rig
        Same triangles, names and regions; ``neutral = f(v_0)``, ``deltas[k] = f(v_0 + dv_k) - f(v_0)``
        (exactly 0 where ``dv_k`` is 0), then changed by the spec's character steps (`Character.apply`,
        which keeps static vertices static and records its ground truth in ``provenance.character``).
        The ``landmarks`` move with the mesh; ``provenance.warp`` (`rigs.WarpRecord`) holds the ``spec``
        (the preset or spec string, else a label such as ``"scale:1.3,1,1+local:mouth,0.7"``) and its
        ``definition`` (the steps as data), and ``provenance.source`` says it was warped.

    Raises
    ------
    ValueError
        For a malformed spec (naming the bad part).
    RigError
        When a named centre cannot be located on the rig (naming the landmark and regions looked for).

    Examples
    --------
    >>> import rigs
    >>> target = warp(rigs.generate("tiny"), "big-eyes")
    >>> target.provenance.warp.spec
    'big-eyes'
    """
    parsed = parse_warp(spec)
    mapped = point_map(parsed, rig)
    neutral = mapped(rig.neutral)
    shape, vertex = np.nonzero(np.any(rig.deltas != 0.0, axis=2))
    deltas = np.zeros_like(rig.deltas)
    deltas[shape, vertex] = mapped(rig.neutral[vertex] + rig.deltas[shape, vertex]) - neutral[vertex]

    label = spec if isinstance(spec, str) else parsed.label()
    source = f"{rig.provenance.label} warped by {label}"
    record = WarpRecord(spec=label, definition=parsed.describe())
    landmarks = dict(rig.landmarks)
    if landmarks:
        landmarks = dict(zip(landmarks, mapped(np.array(list(landmarks.values()))), strict=True))
    provenance = replace(rig.provenance, source=source, warp=record)
    warped = replace(rig, neutral=neutral, deltas=deltas, landmarks=landmarks, provenance=provenance)
    characters = parsed.characters() if isinstance(parsed, Compose) else [parsed]
    for character in characters:
        if isinstance(character, Character):
            warped = character.apply(warped)
    return replace(warped, provenance=replace(warped.provenance, source=source))


def parse_warp(spec: str | Warp | Mapping[str, Any] | Sequence[Any]) -> Warp:
    """A `Warp` from any accepted spec form (see the module documentation).

    Raises
    ------
    ValueError
        Naming the part of the spec that is malformed.
    """
    if isinstance(spec, Scale | LocalScale | Character | Compose):
        return spec
    if isinstance(spec, str):
        steps = [_parse_step(text.strip()) for text in spec.split("+")]
        return steps[0] if len(steps) == 1 else Compose(tuple(steps))
    if isinstance(spec, Mapping):
        return _parse_mapping(spec)
    if isinstance(spec, Sequence) and spec:
        return Compose(tuple(parse_warp(step) for step in spec))
    raise HarnessError(f"warp spec must be a preset name, a string, a dict, a list or a Warp, got {spec!r}")


def _parse_step(text: str) -> Warp:
    if text in WARPS:
        return WARPS[text]
    kind, _, arguments = text.partition(":")
    values = [value.strip() for value in arguments.split(",")] if arguments else []
    try:
        if kind == "scale" and len(values) == 3:
            return Scale(tuple(values))
        if kind == "character" and len(values) in (1, 2):
            return Character(*values)
        if kind == "local" and len(values) in (2, 3):
            center: str | list[str] = values[0]
            if values[0].startswith("[") and values[0].endswith("]"):
                center = values[0][1:-1].split(";")
            radius = values[2] if len(values) == 3 else None
            if radius is not None and radius.endswith("d"):
                return LocalScale(center, values[1], radius_rel=radius[:-1])
            return LocalScale(center, values[1], radius=radius)
    except ValueError as error:
        raise HarnessError(f"warp step {text!r}: {error}") from None
    raise HarnessError(
        f"unknown warp step {text!r}; use a preset ({', '.join(WARPS)}), 'scale:SX,SY,SZ' "
        f"'local:CENTER,FACTOR[,RADIUS]' (CENTER a name or [x;y;z], RADIUS like 2.5 or 0.1d) "
        f"or 'character:STRENGTH[,SEED]'"
    )


def _parse_mapping(spec: Mapping[str, Any]) -> Warp:
    kind = spec.get("kind")
    allowed = {"scale": {"kind", "factors"}, "local": {"kind", "center", "factor", "radius", "radius_rel"}}
    allowed["character"] = {"kind", "strength", "seed"}
    allowed["compose"] = {"kind", "steps"}
    if kind not in allowed:
        raise HarnessError(
            f"warp dict needs 'kind' of scale, local or compose, got {kind!r}; "
            "or character for a character-specific target"
        )
    unknown = sorted(set(spec) - allowed[kind])
    if unknown:
        raise HarnessError(
            f"{kind} warp: unknown key {', '.join(map(repr, unknown))}; allowed: {sorted(allowed[kind])}"
        )
    try:
        if kind == "scale":
            return Scale(spec["factors"])
        if kind == "local":
            return LocalScale(spec["center"], spec["factor"], spec.get("radius"), spec.get("radius_rel"))
        if kind == "character":
            return Character(spec.get("strength", 1.0), spec.get("seed", 0))
        return Compose(tuple(parse_warp(step) for step in spec["steps"]))
    except KeyError as error:
        raise HarnessError(f"{kind} warp: missing key {error.args[0]!r}") from None


def locate(rig: Rig, center: str | tuple[float, float, float]) -> np.ndarray:
    """The point a named centre refers to on ``rig``: its landmark, else the centroid of its regions
    (`LANDMARK_REGIONS`, e.g. the eyelids for ``eye_L``), else the centroid of a region with the centre's
    own name (e.g. an ``eye_L`` eyeball group of a scanned or MakeHuman head).

    Raises
    ------
    RigError
        Naming the centre, the landmark and the regions that were looked for.
    """
    if not isinstance(center, str):
        return np.asarray(center, dtype=float)
    if center in rig.landmarks:
        return np.asarray(rig.landmarks[center], dtype=float)
    candidates = [LANDMARK_REGIONS.get(center, (center,)), (center,)]
    for regions in candidates:
        if all(name in rig.regions and len(rig.regions[name]) for name in regions):
            return region_centre(rig.neutral, rig.regions, regions)
    looked_for = " and ".join(map(repr, candidates[0]))
    if candidates[0] != candidates[1]:
        looked_for += f", nor {center!r}"
    raise RigError(
        f"{rig.provenance.label}: cannot locate {center!r} for the warp: "
        f"no landmark {center!r} and no non-empty region {looked_for}; "
        f"give the centre as coordinates [x, y, z]"
    )
