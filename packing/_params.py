"""The parameters of expression packing, validated once (Carrigan et al. 2020, secs. 4.1-4.4 and 6)."""

from __future__ import annotations

import dataclasses
import difflib
import math
from collections.abc import Mapping
from dataclasses import dataclass
from os import PathLike
from typing import Any, Literal

from packing._constraints import as_pairs
from registry import HarnessError

#: Sketched region pairs for motion symmetry (sec. 4.4.2): upper/lower lip and upper/lower eyelids.
DEFAULT_REGION_PAIRS: tuple[tuple[str, str], ...] = (
    ("upper_lip", "lower_lip"),
    ("upper_eyelid_L", "lower_eyelid_L"),
    ("upper_eyelid_R", "lower_eyelid_R"),
)


@dataclass(frozen=True)
class PackingParams:
    """Every parameter of the method, with the paper's defaults.

    Parameters
    ----------
    mu : float in (0, 1]
        Relative activity threshold of binary blendshapes (eq. 2); the paper recommends 0.25-0.4.
    alpha : float in [0, 1]
        Balance of displacement strength and triangle distortion in the importance (eq. 4).
    beta : float >= 0
        Weight of the uniqueness term (eqs. 4, 8); 0 switches it off.
    importance : bool
        False gives the paper's "no importance" mode: every blendshape weighs 1 (sec. 5.2).
    distortion : {"paper", "excess"}
        Triangle distortion of eq. 6 as printed (``s_t >= 2``, so ``lambda_TD`` of eq. 7 largely counts
        touched triangles) or its excess ``s_t - 2`` as in the authors' code
        (`packing._importance.triangle_distortion`).
    symmetry : bool
        Master switch of the symmetry constraints (eq. 3d); ``shape_symmetry`` and
        ``motion_symmetry`` select the two kinds (secs. 4.4.1, 4.4.2).
    shape_symmetry, motion_symmetry : bool
        Detect mirror pairs (eqs. 9-10) and motion pairs (eqs. 11-12).
    shape_tol : float > 0
        Factor of eq. 10: a pair is symmetric when its error is below ``shape_tol`` times the smaller
        of the two shapes' largest displacements (the paper uses 0.4).
    pair_overlap : float in [0, 1]
        The "small overlap between symmetric pairs" of sec. 4.4.1: a mirror pair whose shapes share more
        than this share of the smaller shape's active vertices *away from the symmetry axis* (outside the
        band of `packing._shape_symmetry.AXIS_BAND`) is not a pair: it spreads over both facial halves, like
        jawLeft/jawRight, and the two would cancel in one expression. Default 0.15: on generated and
        Face Units rigs, true pairs overlap off the axis on at most 6%, spread shapes on at least 32%.
    motion_cos : float in [-1, 1]
        Threshold of eq. 12: mean directions with a cosine below it are opposite (paper: -0.985).
    motion_share : float in (0, 1]
        A blendshape is a motion-symmetry candidate of a sketched region when at least this share of
        its active vertices lies inside that region and none lies in any other sketched region.
    region_pairs : tuple of (str, str)
        The sketched region pairs for motion symmetry.
    regions : mapping or path, optional
        Vertex regions replacing the rig's own: ``{name: vertex indices}`` or a JSON file holding one.
    mirror_tol : float, optional
        Largest distance from a reflected vertex to the mesh surface for it to have a mirror vertex
        (`rigs.mirror_map` with the rig's triangles); default one local edge length, which keeps captured
        neutrals with per-vertex noise of up to half an edge symmetric.
    noise_floor : float >= 0
        A blendshape whose largest displacement is at most ``noise_floor`` times the rig's
        bounding-box diagonal is empty: excluded from packing and reported.
    max_per_expression : int, optional
        Cap on the blendshapes of one expression (sec. 6), counting both shapes of a pair.
    extra_examples : bool
        Second pass of sec. 6: add already-used blendshapes to later expressions where they fit.
    together, apart : tuple of (str, str)
        Artist constraints by shape name (`packing._constraints`): a together pair is one item, like a
        symmetry pair (eq. 3d), and replaces any symmetry pair of its shapes; an apart pair never shares an
        expression (one more conflict row) and is never a symmetry pair. Given as ``"A,B"`` strings or
        pairs of names.
    """

    mu: float = 0.3
    alpha: float = 0.5
    beta: float = 0.0
    importance: bool = True
    distortion: Literal["paper", "excess"] = "paper"
    symmetry: bool = True
    shape_symmetry: bool = True
    motion_symmetry: bool = True
    shape_tol: float = 0.4
    pair_overlap: float = 0.15
    motion_cos: float = -0.985
    motion_share: float = 0.5
    region_pairs: tuple[tuple[str, str], ...] = DEFAULT_REGION_PAIRS
    regions: Mapping[str, Any] | str | PathLike | None = None
    mirror_tol: float | None = None
    noise_floor: float = 1e-6
    max_per_expression: int | None = None
    extra_examples: bool = False
    together: tuple[tuple[str, str], ...] = ()
    apart: tuple[tuple[str, str], ...] = ()

    def __post_init__(self) -> None:
        check_range("mu", self.mu, 0.0, 1.0, low_open=True)
        check_range("alpha", self.alpha, 0.0, 1.0)
        check_range("beta", self.beta, 0.0, math.inf)
        if self.distortion not in ("paper", "excess"):
            raise HarnessError(f"distortion must be 'paper' or 'excess', got {self.distortion!r}")
        check_range("shape_tol", self.shape_tol, 0.0, math.inf, low_open=True)
        check_range("pair_overlap", self.pair_overlap, 0.0, 1.0)
        check_range("motion_cos", self.motion_cos, -1.0, 1.0)
        check_range("motion_share", self.motion_share, 0.0, 1.0, low_open=True)
        check_range("noise_floor", self.noise_floor, 0.0, math.inf)
        if self.mirror_tol is not None:
            check_range("mirror_tol", self.mirror_tol, 0.0, math.inf)
        cap = self.max_per_expression
        if cap is not None and (isinstance(cap, bool) or not isinstance(cap, int) or cap < 1):
            raise HarnessError(f"max_per_expression must be a positive integer or None, got {cap!r}")
        pairs = tuple(tuple(pair) for pair in self.region_pairs)
        if any(len(pair) != 2 or not all(isinstance(name, str) for name in pair) for pair in pairs):
            raise HarnessError(f"region_pairs must be pairs of region names, got {self.region_pairs!r}")
        object.__setattr__(self, "region_pairs", pairs)
        for kind in ("together", "apart"):
            object.__setattr__(self, kind, as_pairs(getattr(self, kind), kind))

    @property
    def use_shape_symmetry(self) -> bool:
        """Whether mirror pairs are detected and enforced."""
        return self.symmetry and self.shape_symmetry

    @property
    def use_motion_symmetry(self) -> bool:
        """Whether motion pairs are detected and enforced."""
        return self.symmetry and self.motion_symmetry

    def as_dict(self) -> dict[str, Any]:
        """Plain values for records (a regions mapping is summarised by its names)."""
        values = dataclasses.asdict(self)
        if isinstance(self.regions, Mapping):
            values["regions"] = sorted(self.regions)
        elif self.regions is not None:
            values["regions"] = str(self.regions)
        for key in ("region_pairs", "together", "apart"):
            values[key] = [list(pair) for pair in getattr(self, key)]
        return values


def params_from(params: PackingParams | None = None, /, **values: Any) -> PackingParams:
    """Validated parameters from keyword arguments (unknown names are an error naming close ones)."""
    known = {f.name for f in dataclasses.fields(PackingParams)}
    unknown = sorted(set(values) - known)
    if unknown:
        hints = [f"{name!r}" + _hint(name, known) for name in unknown]
        raise HarnessError(f"unknown packing parameter {', '.join(hints)}; known: {', '.join(sorted(known))}")
    if params is None:
        return PackingParams(**values)
    return dataclasses.replace(params, **values) if values else params


def _hint(name: str, known: set[str]) -> str:
    close = difflib.get_close_matches(name, sorted(known), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def check_range(name: str, value: Any, low: float, high: float, *, low_open: bool = False) -> None:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise HarnessError(f"{name} must be a number, got {value!r}") from None
    below = number <= low if low_open else number < low
    if math.isnan(number) or below or number > high:
        interval = f"{'(' if low_open else '['}{low:g}, {high:g}{']' if math.isfinite(high) else ')'}"
        raise HarnessError(f"{name} must be in {interval}, got {value!r}")
