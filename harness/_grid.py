"""The experiment grid: rigs x warps x solvers x packing parameters x repetitions, and its presets."""

from __future__ import annotations

import hashlib
import itertools
import json
from dataclasses import asdict, dataclass, fields, replace
from typing import Any

#: J values evaluated by transfer when none are given; each is capped by the sequence's length, so the
#: whole sequence is always evaluated too.
DEFAULT_J_VALUES: tuple[int, ...] = (2, 4, 7, 10, 15, 20, 25)

NO_WARP = "none"


@dataclass(frozen=True)
class CellSpec:
    """One grid point: everything that determines the records of one cell.

    The cell id hashes every field, so a changed parameter never reuses an old result on ``--resume``.
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
    j_values: tuple[int, ...] = DEFAULT_J_VALUES

    @property
    def id(self) -> str:
        """16 hex digits of the SHA-256 of the canonical JSON of the spec."""
        canonical = json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(canonical.encode()).hexdigest()[:16]

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-ready dict (tuples become lists)."""
        return {
            key: list(value) if isinstance(value, tuple) else value for key, value in asdict(self).items()
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> CellSpec:
        """Inverse of `to_dict`."""
        return cls(**{key: tuple(value) if isinstance(value, list) else value for key, value in data.items()})

    def record_fields(self) -> dict[str, Any]:
        """The columns that identify this cell on every record row."""
        identity = {
            f.name: getattr(self, f.name) for f in fields(self) if f.name not in ("transfers", "j_values")
        }
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
        parts.append(f"rep={self.repetition}")
        return " ".join(parts)


@dataclass(frozen=True)
class RunConfig:
    """The exact configuration of a run (stored in ``run.json``; ``--resume`` rebuilds the grid from it).

    Every tuple field is a grid axis; the grid is their Cartesian product with ``repetitions``.
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
    jmax: int | None = None
    j_values: tuple[int, ...] = DEFAULT_J_VALUES
    time_limit: float | None = None
    timeout: float | None = None
    seed: int = 0
    repetitions: int = 1
    preset: str = ""

    def cells(self) -> list[CellSpec]:
        """Every grid point, solvers innermost (neighbouring cells share a rig)."""
        cells = []
        for rig, warp, mu, alpha, beta, symmetry, importance, cap, repetition, solver in itertools.product(
            self.rigs,
            self.warps,
            self.mu,
            self.alpha,
            self.beta,
            self.symmetry,
            self.importance,
            self.cap,
            range(self.repetitions),
            self.solvers,
        ):
            cells.append(
                CellSpec(
                    rig=rig,
                    rig_seed=self.seed,
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
                    seed=self.seed + repetition,
                    transfers=self.transfers,
                    j_values=self.j_values,
                )
            )
        return cells

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-ready dict."""
        return {
            key: list(value) if isinstance(value, tuple) else value for key, value in asdict(self).items()
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> RunConfig:
        """Inverse of `to_dict` (as read back from ``run.json``)."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ValueError(
                f"run.json config has unknown keys {unknown}; this harness knows {sorted(known)}"
            )
        return cls(**{key: tuple(value) if isinstance(value, list) else value for key, value in data.items()})

    def with_overrides(self, **overrides: Any) -> RunConfig:
        """A copy with the given fields replaced (None values are ignored)."""
        return replace(self, **{key: value for key, value in overrides.items() if value is not None})


#: Named grids. ``quick`` is CI's smoke run (<= 60 s on 2 cores), ``paper`` the paper's four test cases
#: (sec. 5.1: each rig against one warped version of itself), ``full`` every preset, warp and setting.
PRESETS: dict[str, dict[str, Any]] = {
    "quick": {
        "rigs": ("tiny", "arkit52"),
        "warps": ("big-eyes",),
        "solvers": ("all",),
        "transfers": ("ebfr", "dt"),
        "j_values": DEFAULT_J_VALUES,
        "time_limit": 10.0,
        "timeout": 60.0,
    },
    "paper": {
        "rigs": ("female", "male", "toon", "digidouble"),
        "warps": ("alien",),
        "solvers": ("all",),
        "transfers": ("ebfr",),
        "jmax": 25,
        "j_values": DEFAULT_J_VALUES,
        "time_limit": 60.0,
        "timeout": 600.0,
    },
    "full": {
        "rigs": ("female", "male", "toon", "digidouble", "arkit52"),
        "warps": ("scale-x1.3", "big-eyes", "small-mouth", "alien"),
        "solvers": ("all",),
        "transfers": ("ebfr", "dt", "plbs"),
        "importance": (True, False),
        "symmetry": (True, False),
        "j_values": DEFAULT_J_VALUES,
        "time_limit": 120.0,
        "timeout": 1800.0,
        "repetitions": 3,
    },
}
