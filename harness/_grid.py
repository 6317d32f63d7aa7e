"""The experiment grid: rigs x warps x solvers x packing parameters x repetitions, and its presets.

A cell is identified by the content of its rig, not by the path naming it (`rig_digest`): a rig file
replaced between an interruption and ``--resume`` gives other cell ids, never a mix of two rigs under one
label.
"""

from __future__ import annotations

import functools
import hashlib
import itertools
import json
import os
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass, fields, replace
from typing import TYPE_CHECKING, Any, TypeVar

from harness._settings import expand, settings_text, split_label
from registry import HarnessError

if TYPE_CHECKING:
    from rigs import RigInputs

#: J values evaluated by transfer when none are given; each is capped by the sequence's length, so the
#: whole sequence is always evaluated too.
DEFAULT_J_VALUES: tuple[int, ...] = (2, 4, 7, 10, 15, 20, 25)

NO_WARP = "none"

#: Training expressions of the transfers: the cell's sequence, ``scan`` (`transfer.scan_expressions`:
#: correctives, scanner noise, head motion removed by rigid alignment; seeded by the cell's seed) or
#: ``ideal`` (the linear sums of the target's ground truth, `transfer.training_expressions`, as the paper's
#: evaluation); or ``random``: the first J of random 0/1 expressions of the target, exact sums, instead of
#: the sequence (`harness._animation`, Wagner et al. 2024, sec. 4.4).
EXAMPLES: tuple[str, ...] = ("scan", "ideal", "random")

#: Cell fields that are the same for every cell of a run and so are no records column.
RUN_LEVEL_FIELDS: tuple[str, ...] = ("transfers", "j_values", "together", "apart", "regions", "frames")

#: Setting fields a variation may change (`RunConfig.variations`).
VARIATION_FIELDS: tuple[str, ...] = ("mu", "alpha", "beta", "symmetry", "importance", "cap", "distortion")

#: Triangle distortion of eq. 6 (`packing.importance`): the paper's ``s_t``, or ``s_t - 2``, its excess
#: over an undistorted triangle (the authors' code).
DISTORTIONS: tuple[str, ...] = ("paper", "excess")

#: A setting field's value: mu, alpha and beta floats, symmetry and importance bools, cap an int or None,
#: distortion a name of `DISTORTIONS`.
SettingValue = float | bool | int | str | None
#: The ``(field, value)`` changes of one variation (`RunConfig.variations`).
Variation = tuple[tuple[str, SettingValue], ...]
#: One point of the setting axes, in `VARIATION_FIELDS` order.
Setting = tuple[float, float, float, bool, bool, int | None, str]

#: The one-at-a-time variations the paper's claims compare (Carrigan et al. 2020, sec. 5.2, Figs. 9-10):
#: no importance, displacement-only and distortion-only importance (alpha 1 and 0), no symmetry; and the
#: excess distortion of eq. 6 against the paper's.
CLAIM_VARIATIONS: tuple[Variation, ...] = (
    (("importance", False),),
    (("alpha", 0.0),),
    (("alpha", 1.0),),
    (("symmetry", False),),
    (("distortion", "excess"),),
)

#: Solvers that run the variations: the paper's greedy and an optimal solver.
CLAIM_SOLVERS: tuple[str, ...] = ("greedy", "cpsat")
#: Transfers of the variations: the claims' method and the two references.
CLAIM_TRANSFERS: tuple[str, ...] = ("ebfr", "dt", "delta")

Pairs = tuple[tuple[str, str], ...]
Regions = tuple[tuple[str, tuple[int, ...]], ...]


def digest_key(argument: str, seed: int) -> str:
    """The key of a rig and generator seed in ``run.json``'s ``rig_digests``: ``tiny@0``."""
    return f"{argument}@{seed}"


def rig_digest(argument: str, seed: int, inputs: RigInputs | None = None) -> str:
    """Content digest of a ``--rigs`` argument: what the cell ids hash instead of the path.

    A rig file or folder hashes everything its read opened (`rigs.RigInputs`: the bytes of every file
    read, the neutral's neighbours, a glTF's buffers, a manifest's targets, and the entries of every
    folder searched; ``inputs`` when the caller has read it already); a generator preset or a fetched rig
    hashes its name, the seed and the preset's parameters (`rigs.PRESETS`).

    Returns
    -------
    str
        ``sha256:`` and 64 hex digits.

    Raises
    ------
    rigs.RigError
        When the rig file cannot be read.
    """
    import rigs

    if inputs is None and os.path.lexists(argument):
        inputs = rigs.load_with_inputs(argument)[1]
    if inputs is not None:
        return inputs.digest
    preset = rigs.PRESETS.get(argument)
    text = json.dumps(["preset", argument, seed, repr(preset)])
    return f"sha256:{hashlib.sha256(text.encode()).hexdigest()}"


def _frozen(value: Any) -> Any:
    """Lists (as read back from JSON) as tuples, recursively."""
    return tuple(_frozen(item) for item in value) if isinstance(value, list | tuple) else value


def _plain(value: Any) -> Any:
    """Tuples as lists, recursively (JSON-ready)."""
    return [_plain(item) for item in value] if isinstance(value, list | tuple) else value


def regions_tuple(regions: Mapping[str, Iterable[int]] | Regions) -> Regions:
    """Vertex regions as a sorted tuple of ``(name, vertex indices)`` (hashable, canonical)."""
    items = regions.items() if isinstance(regions, Mapping) else regions
    return tuple(sorted((str(name), tuple(sorted({int(i) for i in indices}))) for name, indices in items))


#: Cell modes: ``sequence`` (Algorithm 1 with the cell's solver, then transfers) or ``replay`` (the cell's
#: solver on every subproblem of one reference sequence, `harness._replay`).
MODES: tuple[str, ...] = ("sequence", "replay")

#: Cell fields added after cell ids were first recorded, with their defaults: left out of the id there.
_LATE_FIELDS: dict[str, Any] = {"mode": "sequence", "permutation": 0, "frames": 0}
_MISSING = object()

#: The two specs `_to_dict` and `_from_dict` convert.
_Spec = TypeVar("_Spec", "CellSpec", "RunConfig")


def _to_dict(value: CellSpec | RunConfig) -> dict[str, Any]:
    data = {key: _plain(item) for key, item in asdict(value).items()}
    data["regions"] = {name: list(indices) for name, indices in value.regions}
    return data


def _from_dict(cls: type[_Spec], data: Mapping[str, Any]) -> _Spec:
    values = {key: _frozen(item) for key, item in data.items()}
    if "regions" in data:
        values["regions"] = regions_tuple(data["regions"])
    return cls(**values)


#: Cell columns that define a group of cells solving the same problems with different solvers: the
#: sequences, agreement and certificates of solvers are compared within a group.
GROUP_COLUMNS: tuple[str, ...] = (
    "rig",
    "rig_seed",
    "warp",
    "mu",
    "alpha",
    "beta",
    "symmetry",
    "importance",
    "cap",
    "distortion",
    "examples",
    "jmax",
    "time_limit",
    "repetition",
    "mode",
    "permutation",
)


@dataclass(frozen=True)
class CellSpec:
    """One grid point: everything that determines the records of one cell.

    The cell id hashes every field, the content digest of the rig included (`rig_digest`), so a changed
    parameter or rig never reuses an old result on ``--resume``.
    """

    rig: str
    rig_seed: int
    warp: str
    solver: str
    mu: float
    alpha: float
    beta: float
    symmetry: bool
    importance: bool
    cap: int | None
    jmax: int | None
    time_limit: float | None
    repetition: int
    seed: int
    transfers: tuple[str, ...] = ()
    distortion: str = "paper"
    scan_seed: int = 0
    solver_settings: str = ""
    j_values: tuple[int, ...] = DEFAULT_J_VALUES
    rig_digest: str = ""
    together: Pairs = ()
    apart: Pairs = ()
    regions: Regions = ()
    examples: str = "scan"
    mode: str = "sequence"
    permutation: int = 0
    frames: int = 0

    @functools.cached_property
    def id(self) -> str:
        """16 hex digits of the SHA-256 of the canonical JSON of the spec (without the `_LATE_FIELDS` at
        their defaults, so that a cell keeps the id it had before they existed)."""
        data = {
            key: value for key, value in self.to_dict().items() if _LATE_FIELDS.get(key, _MISSING) != value
        }
        canonical = json.dumps(data, sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(canonical.encode()).hexdigest()[:16]

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-ready dict (tuples become lists, regions an object of name -> vertex indices)."""
        return _to_dict(self)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> CellSpec:
        """Inverse of `to_dict`."""
        return _from_dict(cls, data)

    def record_fields(self) -> dict[str, Any]:
        """The columns that identify this cell on every record row (not the `RUN_LEVEL_FIELDS`)."""
        identity = {f.name: getattr(self, f.name) for f in fields(self) if f.name not in RUN_LEVEL_FIELDS}
        return {"cell": self.id, **identity}

    def label(self) -> str:
        """Short human-readable description for progress lines."""
        parts = [self.rig if self.warp == NO_WARP else f"{self.rig}/{self.warp}", self.solver]
        if not self.importance:
            parts.append("no-importance")
        if not self.symmetry:
            parts.append("no-symmetry")
        if self.cap is not None:
            parts.append(f"cap={self.cap}")
        parts.append(f"mu={self.mu:g}")
        parts.append(f"alpha={self.alpha:g}")
        parts.append(f"rep={self.repetition}")
        if self.permutation:
            parts.append(f"perm={self.permutation}")
        if self.mode != "sequence":
            parts.append(self.mode)
        return " ".join(parts)


@dataclass(frozen=True)
class RunConfig:
    """The exact configuration of a run (stored in ``run.json``; ``--resume`` rebuilds the grid from it).

    Every tuple field up to ``distortion``, and ``seed`` (rig and actor generator seeds) and ``examples``
    (`EXAMPLES`: the training expressions of the transfers), is a grid axis; the grid is their Cartesian
    product with ``repetitions``. ``together`` and ``apart`` (artist constraints by shape name) and
    ``regions`` (vertex regions replacing the rigs' own, name -> indices) apply to every cell.

    ``replay`` adds, beside every cell, a ``replay`` cell (`harness._replay`): the cell's solver on the
    subproblems of one reference sequence, without transfers. ``permutations`` is a grid axis like
    ``repetitions``: cell ``permutation`` p > 0 gives the solver each problem with its items shuffled
    (seeded by p, `harness._permute`), 0 in the given order.

    Cells of ``random`` examples train on no sequence, so they run with the first solver only.

    ``frames`` > 0 judges the transfers as Wagner et al.'s Fig. 10 does (`harness._animation`): each transfer
    row records the mean vertex L2 error of that many random source frames retargeted (``frames_l2``)
    instead of the RMS of the transferred rig.

    ``variations`` add cells off the grid: each is a set of ``(field, value)`` changes (`VARIATION_FIELDS`)
    applied to the first value of every axis, run on every rig, warp and repetition with those of
    ``variation_solvers`` the run has, evaluated with those of ``variation_transfers`` it has (the paper
    changes one setting at a time, sec. 5.2). A variation that lands on a grid point adds nothing.
    """

    rigs: tuple[str, ...]
    warps: tuple[str, ...]
    solvers: tuple[str, ...]
    transfers: tuple[str, ...]
    mu: tuple[float, ...] = (0.3,)
    alpha: tuple[float, ...] = (0.5,)
    beta: tuple[float, ...] = (0.0,)
    symmetry: tuple[bool, ...] = (True,)
    importance: tuple[bool, ...] = (True,)
    cap: tuple[int | None, ...] = (None,)
    distortion: tuple[str, ...] = ("paper",)
    jmax: int | None = None
    j_values: tuple[int, ...] = DEFAULT_J_VALUES
    time_limit: float | None = None
    timeout: float | None = None
    seed: tuple[int, ...] = (0,)
    solver_seed: int = 0
    scan_seed: int = 0
    repetitions: int = 1
    preset: str = ""
    together: Pairs = ()
    apart: Pairs = ()
    regions: Regions = ()
    examples: tuple[str, ...] = ("scan",)
    variations: tuple[Variation, ...] = ()
    variation_solvers: tuple[str, ...] = CLAIM_SOLVERS
    variation_transfers: tuple[str, ...] = CLAIM_TRANSFERS
    replay: bool = False
    permutations: int = 1
    frames: int = 0

    def __post_init__(self) -> None:
        if (
            isinstance(self.permutations, bool)
            or not isinstance(self.permutations, int)
            or self.permutations < 1
        ):
            raise HarnessError(f"--permutations must be a positive integer, got {self.permutations!r}")
        if isinstance(self.frames, bool) or not isinstance(self.frames, int) or self.frames < 0:
            raise HarnessError(f"--frames must be a non-negative integer, got {self.frames!r}")
        if not isinstance(self.examples, tuple) or not self.examples or set(self.examples) - set(EXAMPLES):
            raise HarnessError(f"--examples must be among {', '.join(EXAMPLES)}, got {self.examples!r}")
        if not isinstance(self.seed, tuple) or not self.seed:
            raise HarnessError(f"seed must be a tuple of rig generator seeds, got {self.seed!r}")
        unknown = sorted(set(self.distortion) - set(DISTORTIONS))
        if unknown:
            raise HarnessError(
                f"--distortion must be among {', '.join(DISTORTIONS)}, got {', '.join(unknown)}"
            )
        for variation in self.variations:
            if not variation or any(len(change) != 2 for change in variation):
                raise HarnessError(f"a variation must be (field, value) pairs, got {_plain(variation)!r}")
            unknown = sorted({field for field, _ in variation} - set(VARIATION_FIELDS))
            if unknown:
                raise HarnessError(
                    f"variation {_plain(variation)!r} changes {', '.join(unknown)}; a variation may change "
                    f"{', '.join(VARIATION_FIELDS)}"
                )

    def cells(self, digests: Mapping[str, str] | None = None) -> list[CellSpec]:
        """Every grid point, solvers innermost (neighbouring cells share a rig), then the variations.

        Parameters
        ----------
        digests : mapping, optional
            `rig_digest` of each rig argument and seed, by `digest_key` (the run computes them once);
            without them the cells carry no rig digest.
        """
        digests = digests or {}
        settings = list(
            itertools.product(
                self.mu, self.alpha, self.beta, self.symmetry, self.importance, self.cap, self.distortion
            )
        )
        cells = {
            replace(
                self._cell(rig, seed, warp, setting, repetition, solver, digests, examples), permutation=p
            ): None
            for rig, seed, warp, setting, examples, repetition, p, solver in itertools.product(
                self.rigs,
                self.seed,
                self.warps,
                settings,
                self.examples,
                range(self.repetitions),
                range(self.permutations),
                self.solvers,
            )
            if examples != "random" or solver == self.solvers[0]  # random examples ignore the solver
        }
        if settings and self.variations:
            solvers = [solver for solver in self.variation_solvers if solver in self.solvers]
            base = dict(zip(VARIATION_FIELDS, settings[0], strict=True))
            varied = [tuple({**base, **dict(variation)}.values()) for variation in self.variations]
            transfers = tuple(name for name in self.transfers if name in self.variation_transfers)
            for rig, seed, warp, setting, examples, repetition, solver in itertools.product(
                self.rigs, self.seed, self.warps, varied, self.examples, range(self.repetitions), solvers
            ):
                cell = self._cell(rig, seed, warp, setting, repetition, solver, digests, examples)
                if cell not in cells:  # a grid point already runs it, with every transfer
                    cells[replace(cell, transfers=transfers)] = None
        if self.replay:
            cells.update({replace(cell, mode="replay", transfers=()): None for cell in list(cells)})
        return list(cells)

    def _cell(
        self,
        rig: str,
        seed: int,
        warp: str,
        setting: Setting,
        repetition: int,
        solver: str,
        digests: Mapping[str, str],
        examples: str,
    ) -> CellSpec:
        mu, alpha, beta, symmetry, importance, cap, distortion = setting
        return CellSpec(
            rig=rig,
            rig_seed=seed,
            warp=warp,
            solver=solver,
            mu=float(mu),
            alpha=float(alpha),
            beta=float(beta),
            symmetry=bool(symmetry),
            importance=bool(importance),
            cap=cap,
            jmax=self.jmax,
            time_limit=self.time_limit,
            repetition=repetition,
            seed=self.solver_seed + repetition,
            transfers=self.transfers,
            distortion=distortion,
            scan_seed=self.scan_seed + repetition,
            solver_settings=settings_text(split_label(solver)[1]),
            j_values=self.j_values,
            rig_digest=digests.get(digest_key(rig, seed), ""),
            together=self.together,
            apart=self.apart,
            regions=self.regions,
            examples=examples,
            frames=self.frames,
        )

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-ready dict (regions an object of name -> vertex indices)."""
        return _to_dict(self)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> RunConfig:
        """Inverse of `to_dict` (as read back from ``run.json``)."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise HarnessError(
                f"run.json config has unknown keys {unknown}; this harness knows {sorted(known)}"
            )
        return _from_dict(cls, data)

    def with_overrides(self, **overrides: object) -> RunConfig:
        """A copy with the given fields replaced (None values are ignored)."""
        return replace(self, **{key: value for key, value in overrides.items() if value is not None})


#: Transfers of the ``fig10`` preset: AnaConDaR and ALM (the same patchwise blend alone) with Table 3's
#: ridge read in millimetres, and again read in face diagonals (0.01 x 300^2 mm^2), where it keeps the blend
#: from inflating unrelated examples; EBFR beside.
FIG10_TRANSFERS: tuple[str, ...] = (
    "anacondar",
    "anacondar[missing=off,anacon=off]",
    "anacondar[lambda_reg=900]",
    "anacondar[lambda_reg=900,missing=off,anacon=off]",
    "ebfr",
)

#: Named grids. ``quick`` is CI's smoke run (<= 60 s on 2 cores). ``paper`` is the paper's four test cases
#: (sec. 5.1: each rig against one warped version of itself), made character-specific (``alien+character``,
#: `rigs.warp`) so that training expressions matter, with the one-at-a-time variations its claims compare
#: (`CLAIM_VARIATIONS`) and the two references every RMS is reported against (``dt`` and ``delta``).
#: ``exact`` separates the exact backends: the first 40 expressions of the 1,000-shape film rig, the
#: largest problems of its sequence (hundreds of items each), three repetitions so that `harness compare`
#: can test their times. ``sanity`` checks the evaluation itself on three faces (the claims' unit of
#: evidence): every shape in an expression of its own (cap 1, no symmetry) and every expression a training
#: example, ideal and scan-like, so that example-based
#: rigging has all it could ever have; it must come close to the truth (the claims table's sanity row),
#: and ebfr's balance beta swept over five decades shows where fitting scan noise begins; anacondar must
#: come close too. ``fig10`` is Wagner et al.'s quantitative comparison (2024, sec. 4.4): the paper's four
#: rigs over five faces, 5 random source frames retargeted by AnaConDaR and by ALM (its patchwise blend
#: alone, `FIG10_TRANSFERS`) and EBFR, trained on J random examples or on the first J expressions packed by
#: cpsat and greedy (exact sums both). ``full`` is every preset, warp and setting. Every other preset
#: trains on scan-like expressions.
PRESETS: dict[str, dict[str, Any]] = {
    "quick": {
        "rigs": ("tiny", "arkit52"),
        "warps": ("big-eyes",),
        "solvers": ("all",),
        "transfers": ("ebfr", "dt", "delta"),
        "j_values": DEFAULT_J_VALUES,
        "time_limit": 10.0,
        "timeout": 60.0,
    },
    "paper": {
        "rigs": ("female", "male", "toon", "digidouble"),
        "warps": ("alien+character",),
        "solvers": ("all",),
        "transfers": ("ebfr", "plbs", "dt", "delta"),
        "jmax": 25,
        "j_values": DEFAULT_J_VALUES,
        "time_limit": 60.0,
        "timeout": 600.0,
        "variations": CLAIM_VARIATIONS,
    },
    "exact": {
        "rigs": ("film",),
        "warps": ("alien",),
        "solvers": ("cpsat", "highs", "scip", "cbc-mip", "cbc-pulp"),
        "transfers": (),
        "jmax": 40,
        "repetitions": 3,
        "time_limit": 60.0,
        "timeout": 900.0,
    },
    "sanity": {
        "rigs": ("toon",),
        "warps": ("alien+character",),
        "solvers": ("greedy",),
        "transfers": ("ebfr", *expand("ebfr[beta=0.0001,0.001,0.01,0.1,1]"), "dt", "anacondar"),
        "cap": (1,),
        "symmetry": (False,),
        "examples": ("ideal", "scan"),
        "seed": (0, 1, 2),
        "j_values": (10_000,),
        "time_limit": 10.0,
        "timeout": 600.0,
    },
    "fig10": {
        "rigs": ("female", "male", "toon", "digidouble"),
        "warps": ("alien+character",),
        "seed": (0, 1, 2, 3, 4),
        "solvers": ("cpsat", "greedy"),
        "transfers": FIG10_TRANSFERS,
        "examples": ("random", "ideal"),
        "frames": 5,
        "jmax": 30,
        "j_values": (5, 10, 15, 20, 30),
        "time_limit": 60.0,
        "timeout": 3600.0,
    },
    "full": {
        "rigs": ("female", "male", "toon", "digidouble", "arkit52"),
        "warps": ("scale-x1.3", "big-eyes", "small-mouth", "alien", "alien+character"),
        "solvers": ("all",),
        "transfers": ("ebfr", "plbs", "dt", "delta"),
        "importance": (True, False),
        "symmetry": (True, False),
        "alpha": (0.5, 0.0, 1.0),
        "j_values": DEFAULT_J_VALUES,
        "time_limit": 120.0,
        "timeout": 1800.0,
        "repetitions": 3,
    },
}
