"""Fixtures for the reports tests: a small face rig and fabricated run directories in the records schema.

A fabricated run is what `harness run` writes (``run.json``, ``records/<cell>.parquet``), built here from
explicit expression sequences and times so that each test knows every expected number; the agreement of its
solvers (Table 3), counted here by hand, is kept in `EXPECTED_AGREEMENT`.
"""

from __future__ import annotations

import hashlib
import itertools
import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import harness
import rigs

SHAPES = (
    "browUp_L",
    "browUp_R",
    "jawOpen",
    "smile_L",
    "smile_R",
    "noseWrinkle",
    "foreheadRaise",
    "cheekPuff_L",
    "cheekPuff_R",
)
_CENTRES = (
    (-0.5, 0.6),
    (0.5, 0.6),
    (0.0, -0.7),
    (-0.4, -0.6),
    (0.4, -0.6),
    (0.0, 0.0),
    (0.0, 0.9),
    (-0.6, 0.0),
    (0.6, 0.0),
)

#: Importance weight per shape used to fabricate objectives (sum over an expression's shapes).
WEIGHTS = {name: 0.5 + 0.05 * i for i, name in enumerate(SHAPES)}

OPTIMAL = [
    ["browUp_L", "browUp_R", "jawOpen"],
    ["smile_L", "smile_R", "noseWrinkle"],
    ["foreheadRaise", "cheekPuff_L", "cheekPuff_R"],
]
GREEDY = [
    ["browUp_L", "browUp_R"],
    ["jawOpen", "smile_L", "smile_R", "noseWrinkle", "foreheadRaise"],
    ["cheekPuff_L", "cheekPuff_R"],
]


#: Per fabricated run folder, its agreement rows (`reports.AGREEMENT_COLUMNS`) counted by hand.
EXPECTED_AGREEMENT: dict[Path, list[dict[str, object]]] = {}


def face_rig(resolution: int = 40) -> rigs.Rig:
    """A dome-shaped grid 'face' with nine Gaussian bump blendshapes at brow, mouth, nose and cheek spots."""
    x, y = np.meshgrid(np.linspace(-1, 1, resolution), np.linspace(-1.3, 1.3, resolution))
    z = np.sqrt(np.clip(2.5 - x**2 - 0.6 * y**2, 0, None))
    neutral = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    corner = (np.arange(resolution - 1)[:, None] * resolution + np.arange(resolution - 1)[None, :]).ravel()
    triangles = np.concatenate(
        [
            np.stack([corner, corner + 1, corner + resolution], axis=1),
            np.stack([corner + 1, corner + resolution + 1, corner + resolution], axis=1),
        ]
    )
    deltas = np.array(
        [
            np.exp(-((neutral[:, 0] - cx) ** 2 + (neutral[:, 1] - cy) ** 2) / 0.05)[:, None]
            * [0.0, 0.05, 0.15]
            for cx, cy in _CENTRES
        ]
    )
    return rigs.Rig(neutral, deltas, triangles, SHAPES, provenance=rigs.Provenance(source="face fixture"))


@dataclass
class RunSpec:
    """What a fabricated run holds: per solver its sequence and seconds per expression (build + solve)."""

    rig: str
    n_vertices: int = 1600
    sequences: dict[str, list[list[str]]] = field(
        default_factory=lambda: {
            "naive-pulp-cbc": OPTIMAL,
            "highs": OPTIMAL,
            "cpsat": OPTIMAL,
            "greedy": GREEDY,
        }
    )
    seconds: dict[str, float] = field(
        default_factory=lambda: {"naive-pulp-cbc": 2.0, "highs": 0.02, "cpsat": 0.03, "greedy": 0.001}
    )
    repetitions: int = 2
    transfers: tuple[str, ...] = ("ebfr", "dt")
    importance: tuple[bool, ...] = (True,)
    lower_bound: int = 3
    jitter: float = 0.1  # relative time change from one repetition to the next, the same for every solver
    wobble: float = 0.0  # each solver's own relative time change per repetition, up to this much either way
    wobble_seed: int = 0  # which wobble: runs of one spec and seed wobble alike
    skipped: dict[str, str] = field(default_factory=dict)
    objective_scale: float = 1.0  # multiplies every objective (to fake floating-point noise)
    noise: float = 0.0  # relative change of the learned transfers' RMS from one repetition to the next
    cpu_model: str | None = None  # the processor model run.json records (None: not recorded)
    cpu: bool = True  # whether the records hold each solve's CPU time (0.9 of its seconds)


#: Relative size of each transfer's fabricated error (the references ignore the expressions).
_SCALE = {"dt": 1.0, "delta": 1.2, "ebfr": 0.6, "plbs": 0.5}


def _rms(covered: int, transfer: str, importance: bool, repetition: int = 0, noise: float = 0.0) -> float:
    if transfer in ("dt", "delta"):
        return _SCALE[transfer] / 4.0
    wobble = 1.0 + noise * (repetition - 0.5)
    return _SCALE[transfer] * (1.1 if not importance else 1.0) / (1.0 + covered) * wobble


def _wobble(spec: RunSpec, solver: str, repetition: int) -> float:
    """A factor in ``[1 - spec.wobble, 1 + spec.wobble]``, fixed by solver, repetition and ``wobble_seed``."""
    key = hashlib.sha256(json.dumps([solver, repetition, spec.wobble_seed]).encode()).digest()
    return 1.0 + spec.wobble * (2.0 * int.from_bytes(key[:8]) / 2**64 - 1.0)


def cell_group(rig: str, *, importance: bool = True, repetition: int = 0) -> dict[str, object]:
    """The `harness.GROUP_COLUMNS` of a fabricated cell: ``rig`` with the ``alien`` warp and the default
    settings of `harness run`."""
    return {
        "rig": rig,
        "rig_seed": 0,
        "warp": "alien",
        "mu": 0.3,
        "alpha": 0.5,
        "beta": 0.0,
        "symmetry": True,
        "importance": importance,
        "cap": None,
        "distortion": "paper",
        "examples": "scan",
        "jmax": None,
        "time_limit": None,
        "repetition": repetition,
        "mode": "sequence",
        "permutation": 0,
    }


def fabricate_run(out: Path, spec: RunSpec) -> Path:
    """Write a run directory for ``spec`` exactly as `harness run` lays one out; returns ``out``."""
    records_dir = out / "records"
    records_dir.mkdir(parents=True)
    schema = pa.schema(list(harness.RECORD_COLUMNS.items()))
    group_rows = []
    for importance, repetition in itertools.product(spec.importance, range(spec.repetitions)):
        setting = cell_group(spec.rig, importance=importance, repetition=repetition)
        group_rows.append((setting, {}))
        for solver in [*spec.sequences, *spec.skipped]:
            cell = hashlib.sha256(json.dumps([setting, solver], sort_keys=True).encode()).hexdigest()[:16]
            base = {
                **setting,
                "cell": cell,
                "solver": solver,
                "seed": repetition,
                "n_vertices": spec.n_vertices,
                "n_shapes": len(SHAPES),
                "message": "",
            }
            if solver in spec.skipped:
                rows = [{**base, "kind": "cell", "status": "skipped", "message": spec.skipped[solver]}]
                pq.write_table(pa.Table.from_pylist(rows, schema=schema), records_dir / f"{cell}.parquet")
                continue
            sequence = spec.sequences[solver]
            seconds = (
                spec.seconds[solver] * (1.0 + spec.jitter * repetition) * _wobble(spec, solver, repetition)
            )
            group_rows[-1][1][solver] = sequence
            rows, covered = [], 0
            for position, shapes in enumerate(sequence, start=1):
                covered += len(shapes)
                rows.append(
                    {
                        **base,
                        "kind": "expression",
                        "status": "optimal",
                        "expression": position,
                        "shapes": shapes,
                        "n_chosen": len(shapes),
                        "extra_examples": [],
                        "objective": spec.objective_scale * sum(WEIGHTS[name] for name in shapes),
                        "termination": "optimal",
                        "presolve_time": 0.1 * seconds,
                        "build_time": 0.25 * seconds,
                        "solve_time": 0.65 * seconds,
                        "cpu_time": 0.9 * seconds if spec.cpu else None,
                        "covered": covered,
                        "coverage": covered / len(SHAPES),
                    }
                )
            for transfer, j in itertools.product(spec.transfers, range(1, len(sequence) + 1)):
                covered_j = sum(len(shapes) for shapes in sequence[:j])
                worst = ([name for shapes in sequence[j:] for name in shapes] or [SHAPES[0]])[:2]
                value = _rms(covered_j, transfer, importance, repetition, spec.noise)
                rows.append(
                    {
                        **base,
                        "kind": "transfer",
                        "status": "ok",
                        "transfer": transfer,
                        "j": j,
                        "rms": value,
                        "rms_covered": 0.5 * value,
                        "rms_uncovered": 2 * value,
                        "worst_shapes": worst,
                        "worst_rms": [(3.0 - i) * value for i in range(len(worst))],
                        "transfer_time": 0.1,
                    }
                )
            rows.append(
                {
                    **base,
                    "kind": "cell",
                    "status": "ok",
                    "analysis_time": 0.05,
                    "sequence_time": seconds * len(sequence),
                    "cell_time": seconds * len(sequence) + 0.3,
                    "n_expressions": len(sequence),
                    "n_covered": covered,
                    "n_pairs": 3,
                    "n_empty": 0,
                    "lower_bound": spec.lower_bound,
                    "backend_version": f"{solver} 1.0",
                    "worker": "host:1",
                    "finished": "2026-11-22T00:00:00+00:00",
                }
            )
            pq.write_table(pa.Table.from_pylist(rows, schema=schema), records_dir / f"{cell}.parquet")
    agreement = []
    for setting, sequences in group_rows:
        for a, b in itertools.combinations(sorted(sequences), 2):
            for first in (5, 10, 20):
                shapes_a = {s for shapes in sequences[a][:first] for s in shapes}
                shapes_b = {s for shapes in sequences[b][:first] for s in shapes}
                agreement.append(
                    {
                        **setting,
                        "solver_a": a,
                        "solver_b": b,
                        "first": first,
                        "expressions_a": min(first, len(sequences[a])),
                        "expressions_b": min(first, len(sequences[b])),
                        "shapes_a": len(shapes_a),
                        "shapes_b": len(shapes_b),
                        "shared": len(shapes_a & shapes_b),
                    }
                )
    EXPECTED_AGREEMENT[Path(out)] = agreement
    run = {
        "format": 1,
        "state": "complete",
        "command": ["harness", "run", "--out", str(out)],
        "config": {},
        "versions": {},
        "git": {"commit": None, "dirty": None},
        "machine": {
            "hostname": "test",
            "platform": "linux",
            "cpu_count": 2,
            "python": "3.11",
            "cpu_model": spec.cpu_model,
        },
        "started": "2026-11-22T00:00:00+00:00",
        "finished": "2026-11-22T00:01:00+00:00",
        "resumed": [],
    }
    (out / "run.json").write_text(json.dumps(run, indent=1))
    return out


@pytest.fixture(scope="session")
def face_rig_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The face rig saved as a native rig file, so runs can name it and reports can reload it."""
    path = tmp_path_factory.mktemp("rig") / "face.npz"
    rigs.save(face_rig(), path)
    return path


@pytest.fixture(scope="session")
def fabricate(face_rig_file: Path):
    """Factory: ``fabricate(out, **RunSpec fields)`` writes a run on the face rig into new folder ``out``."""

    def make(out: Path, **fields) -> Path:
        fields.setdefault("rig", str(face_rig_file))
        return fabricate_run(out, RunSpec(**fields))

    return make


@pytest.fixture
def make_run(tmp_path: Path, fabricate):
    """Factory: ``make_run(name, **RunSpec fields)`` fabricates a run on the face rig under ``tmp_path``."""
    return lambda name, **fields: fabricate(tmp_path / name, **fields)


@pytest.fixture(scope="session")
def expected_agreement() -> dict[Path, list[dict[str, object]]]:
    """Per fabricated run folder, its agreement rows counted by hand (`EXPECTED_AGREEMENT`)."""
    return EXPECTED_AGREEMENT


@pytest.fixture(scope="session")
def group() -> Callable[..., dict[str, object]]:
    """The group columns of a fabricated cell: ``group(rig, importance=True, repetition=0)``."""
    return cell_group


@pytest.fixture(scope="session")
def face() -> rigs.Rig:
    """The face rig in memory."""
    return face_rig()


@pytest.fixture(scope="session")
def fabric() -> dict:
    """The fabricated runs' building blocks: shape names, weights, the optimal and greedy sequences."""
    return {"shapes": SHAPES, "weights": WEIGHTS, "optimal": OPTIMAL, "greedy": GREEDY}
