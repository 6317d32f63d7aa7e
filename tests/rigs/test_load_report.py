"""What a load notes about a rig it keeps: identical shapes, names equal up to case, a neutral that is no
surface. Each is named in one `RigWarning` and in the rig's ``load_report``."""

from __future__ import annotations

import re

import numpy as np
import pytest

import rigs
from rigs import RigWarning


def _rig(names=("lift", "rest", "copy"), triangles=((0, 1, 2), (1, 3, 2)), neutral=None) -> rigs.Rig:
    neutral = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]) if neutral is None else neutral
    deltas = np.zeros((len(names), len(neutral), 3))
    deltas[0, 0, 2] = 0.5
    deltas[1, 3, 2] = 0.25
    deltas[2:, 0, 2] = 0.5  # every later shape is a copy of the first
    return rigs.Rig(neutral, deltas, np.array(triangles, dtype=np.int64).reshape(-1, 3), names)


def _load(rig: rigs.Rig, tmp_path) -> tuple[rigs.Rig, list[str]]:
    path = rigs.save(rig, tmp_path / "face.npz")
    with pytest.warns(RigWarning) as caught:
        loaded = rigs.load(path, noise_floor=1e-6)
    return loaded, [str(warning.message) for warning in caught]


def test_identical_shapes_are_named(tmp_path) -> None:
    loaded, said = _load(_rig(names=("lift", "rest", "copy", "again")), tmp_path)
    assert loaded.load_report.identical_shapes == (("lift", "copy", "again"),)
    assert any("face.npz: shapes lift, copy, again are identical" in line for line in said)


def test_names_equal_up_to_case_are_named(tmp_path) -> None:
    loaded, said = _load(_rig(names=("jawOpen", "rest", "JawOpen")), tmp_path)
    assert loaded.load_report.case_twins == (("jawOpen", "JawOpen"),)
    assert any("shape names jawOpen, JawOpen differ only in case" in line for line in said)


@pytest.mark.parametrize(
    ("triangles", "neutral", "said"),
    [
        ((), None, "the neutral has no faces (4 points)"),
        (((0, 1, 2),), np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]]), "zero area"),
        (((0, 0, 0),), None, "zero area"),
    ],
    ids=["no-faces", "colinear", "collapsed"],
)
def test_a_neutral_that_is_no_surface_is_noted(triangles, neutral, said, tmp_path) -> None:
    _, lines = _load(_rig(names=("lift", "rest"), triangles=triangles, neutral=neutral), tmp_path)
    assert any(said in line and "cannot be pictured or transferred" in line for line in lines), lines


def test_a_plain_rig_loads_without_notes(tmp_path, recwarn) -> None:
    loaded = rigs.load(rigs.save(_rig(names=("lift", "rest")), tmp_path / "face.npz"), noise_floor=1e-6)
    assert loaded.load_report.identical_shapes == () and loaded.load_report.case_twins == ()
    assert not [w for w in recwarn if issubclass(w.category, RigWarning)]


@pytest.mark.parametrize(
    ("case", "expected"),
    [("shifted", range(600, 1222)), ("five moved", range(1, 6)), ("noisy", None)],
)
def test_a_neutral_out_of_line_with_its_shapes_is_noted(case, expected, tmp_path, recwarn) -> None:
    """A neutral moved after its shapes were made (or saved from another pose) adds the same offset to
    every delta: said, with how many vertices and how far. Noise of either sign on every shape is not."""
    rig = rigs.generate("arkit52")
    rng = np.random.default_rng(0)
    offset = np.zeros_like(rig.neutral)
    if case == "shifted":
        offset[:] = [0.0, 0.005 * rig.diagonal(), 0.0]
    elif case == "five moved":
        offset[rng.choice(rig.n_vertices, 5, replace=False)] = (
            0.005 * rig.diagonal() * rng.normal(size=(5, 3))
        )
    deltas = rig.deltas - offset
    if case == "noisy":
        deltas = deltas + rng.normal(scale=2e-4 * rig.diagonal(), size=deltas.shape)
    moved = rigs.Rig(rig.neutral + offset, deltas, rig.triangles, rig.names)
    loaded = rigs.load(rigs.save(moved, tmp_path / "face.npz"))
    said = [str(w.message) for w in recwarn if issubclass(w.category, RigWarning)]
    noted = [line for line in said if "the neutral does not line up with the shapes" in line]
    if expected is None:
        assert not noted, said
    else:  # (a vertex some shape moves against the offset, further than it, is not counted)
        counted = re.search(
            r"face\.npz: (\d+) of its 1221 vertices are moved the same way by every one", noted[0]
        )
        assert len(noted) == 1 and counted and int(counted[1]) in expected, said
    assert loaded.n_shapes == rig.n_shapes


def test_a_collapsed_neutral_whose_shapes_all_move_one_vertex_loads_with_its_notes(tmp_path, recwarn) -> None:
    deltas = np.zeros((8, 4, 3))
    deltas[:, 0, 2] = np.linspace(0.1, 0.8, 8)  # (every shape lifts vertex 0, none alike)
    names = tuple(f"s{k}" for k in range(8))
    rig = rigs.Rig(np.zeros((4, 3)), deltas, np.array([[0, 1, 2], [1, 3, 2]]), names)
    loaded = rigs.load(rigs.save(rig, tmp_path / "face.npz"))
    said = [str(w.message) for w in recwarn if issubclass(w.category, RigWarning)]
    assert loaded.n_shapes == 8 and any("moved the same way by every one of its 8" in line for line in said)
    assert any("zero area" in line for line in said)


@pytest.mark.parametrize(("noise_floor", "warned"), [(None, True), (1e-2, False)])
def test_shapes_that_move_every_vertex_are_noted_as_noise(noise_floor, warned, tmp_path, recwarn) -> None:
    """Noise on every displacement makes every shape overlap every other one: the load says so, unless a
    noise floor above the noise zeroes it."""
    tiny = rigs.generate("tiny")
    noise = np.random.default_rng(0).normal(scale=1e-3 * tiny.diagonal(), size=tiny.deltas.shape)
    path = rigs.save(
        rigs.Rig(tiny.neutral, tiny.deltas + noise, tiny.triangles, tiny.names), tmp_path / "n.npz"
    )
    assert rigs.moving_everywhere(rigs.load(path, noise_floor=0).deltas).all()
    recwarn.clear()
    loaded = rigs.load(path, noise_floor=noise_floor)
    said = [str(warning.message) for warning in recwarn if warning.category is RigWarning]
    expected = f"n.npz: 12 of its 12 blendshapes move at least 99% of its {tiny.n_vertices} vertices"
    assert any(expected in line for line in said) is warned
    assert bool(rigs.moving_everywhere(loaded.deltas).any()) is warned
