"""A rig format is one module and one registration line: a format made here is detected, read, written,
digested and packed by the harness, which knows no format by name."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import rigs
from harness.cli import cli
from rigs import Rig, RigError
from rigs._format_table import REGISTERED, RigFormat
from rigs._formats import register_format
from rigs._safe import read_bytes


def read_points(path: Path) -> Rig:
    """A rig from a ``.points`` file: JSON of ``neutral``, ``triangles`` and ``shapes`` (name: positions)."""
    try:
        document = json.loads(read_bytes(Path(path), limit=2**20))
        neutral = np.asarray(document["neutral"], dtype=float)
        shapes = document["shapes"]
        deltas = np.stack([np.asarray(shapes[name], dtype=float) - neutral for name in shapes])
        triangles = np.asarray(document["triangles"], dtype=np.int64)
    except (ValueError, KeyError, TypeError) as error:
        raise RigError(f"{path}: not a points rig: {error}") from None
    return Rig(neutral=neutral, deltas=deltas, triangles=triangles, names=tuple(shapes))


def write_points(rig: Rig, path: Path) -> Path:
    """Write ``rig`` as a ``.points`` file."""
    shapes = {name: (rig.neutral + rig.deltas[k]).tolist() for k, name in enumerate(rig.names)}
    document = {"neutral": rig.neutral.tolist(), "triangles": rig.triangles.tolist(), "shapes": shapes}
    Path(path).write_text(json.dumps(document))
    return Path(path)


POINTS = RigFormat(
    "points",
    (".points",),
    read_points,
    write=write_points,
    write_suffixes=(".points",),
    self_contained=(".points",),
)


@pytest.fixture
def points_format(monkeypatch):
    """The registry with the ``points`` format added (as a format module would at import)."""
    rigs.formats()  # the built-in formats first
    monkeypatch.setattr("rigs._format_table.REGISTERED", dict(REGISTERED))
    register_format(POINTS)  # the one registration line
    return POINTS


def grid_rig() -> Rig:
    """A 6 x 6 grid with two shapes that move disjoint corners, so that both fit one expression."""
    xs, ys = np.meshgrid(np.arange(6.0), np.arange(6.0))
    neutral = np.column_stack([xs.ravel(), ys.ravel(), np.zeros(36)])
    quads = [
        (6 * row + col, 6 * row + col + 1, 6 * row + col + 7, 6 * row + col + 6)
        for row in range(5)
        for col in range(5)
    ]
    triangles = np.array([tri for a, b, c, d in quads for tri in ((a, b, c), (a, c, d))])
    deltas = np.zeros((2, 36, 3))
    deltas[0, :8, 2] = 0.5
    deltas[1, -8:, 2] = 0.5
    return Rig(neutral=neutral, deltas=deltas, triangles=triangles, names=("browUp", "chinUp"))


def test_a_registered_format_is_detected_read_and_written(tmp_path, points_format) -> None:
    path = rigs.save(grid_rig(), tmp_path / "face.points")
    assert rigs.detect_format(path) is points_format
    rig = rigs.load(path)
    assert rig.names == ("browUp", "chinUp")
    np.testing.assert_array_equal(rig.deltas, grid_rig().deltas)
    assert rig.load_report.empty_shapes == ()  # the load report of every interchange format
    with pytest.raises(RigError, match=r"face\.points: unknown option 'weld' for points \(accepted: none\)"):
        rigs.load(path, weld=True)


def test_a_format_the_registry_lacks_is_named_with_the_known_ones(tmp_path) -> None:
    (tmp_path / "face.points").write_text("{}")
    with pytest.raises(RigError, match=r"unknown rig format '\.points' \(\.glb, \.gltf, .*\.zip"):
        rigs.load(tmp_path / "face.points")
    with pytest.raises(
        RigError, match=r"unknown format 'points' \(one of npz, gltf, usd, target, obj-folder\)"
    ):
        rigs.load(tmp_path / "face.points", format="points")


def test_a_format_name_is_registered_once(points_format) -> None:
    register_format(points_format)  # the same format again: a module imported twice
    with pytest.raises(ValueError, match="rig format 'points' is registered twice"):
        register_format(RigFormat("points", (".pts",), read_points))


def test_the_digest_covers_what_the_format_read(tmp_path, points_format) -> None:
    path = rigs.save(grid_rig(), tmp_path / "face.points")
    _, before = rigs.load_with_inputs(path)
    deltas = grid_rig().deltas.copy()
    deltas[1, -1, 2] = 0.75
    rigs.save(dataclasses.replace(grid_rig(), deltas=deltas), path)
    _, after = rigs.load_with_inputs(path)
    assert before.digest != after.digest


def test_the_harness_reads_a_format_it_does_not_know_by_name(tmp_path, points_format) -> None:
    (tmp_path / "rig").mkdir()
    path = rigs.save(grid_rig(), tmp_path / "rig" / "face.points")
    assert rigs.argument_paths(str(path)) == [path]  # the format reads the file alone
    out = tmp_path / "session"
    result = CliRunner().invoke(
        cli,
        ["pack", str(path), "--out", str(out), "--no-pictures", "--solver", "greedy"],
        catch_exceptions=False,
    )
    assert result.exit_code == 0, result.output
    document = json.loads((out / "expressions.json").read_text())
    assert [sorted(expression["shapes"]) for expression in document["expressions"]] == [["browUp", "chinUp"]]
