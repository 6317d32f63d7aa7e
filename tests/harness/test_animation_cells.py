"""Wagner et al.'s Fig. 10 protocol in the grid: random examples (``--examples random``) and retargeted
source frames (``--frames``) judged by their mean vertex L2 error (`harness._animation`)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import harness
import rigs
import transfer
from harness import _animation
from harness._cell import run_cell


def spec(**fields) -> harness.CellSpec:
    config = harness.RunConfig(
        rigs=("tiny",),
        warps=("big-eyes+character",),
        solvers=("greedy",),
        transfers=("ebfr",),
        j_values=(2, 4),
    )
    return replace(config.cells()[0], **fields)


def transfer_rows(cell: harness.CellSpec) -> list[dict]:
    rows = run_cell(cell)
    assert rows[0]["status"] == "ok", rows[0]["message"]
    found = [row for row in rows if row["kind"] == "transfer"]
    assert all(row["status"] == "ok" for row in found), [row["message"] for row in found]
    return found


def test_random_draws_are_seeded_binary_examples_and_weighted_frames():
    rig = rigs.generate("tiny")
    examples = _animation.random_examples(rig, 6, rig_seed=0, scan_seed=0)
    counts = (examples != 0).sum(axis=1)
    assert set(np.unique(examples)) <= {0.0, 1.0} and counts.min() >= 3 and counts.max() <= 8
    assert np.array_equal(examples, _animation.random_examples(rig, 6, rig_seed=0, scan_seed=0))
    assert not np.array_equal(examples, _animation.random_examples(rig, 6, rig_seed=0, scan_seed=1))
    assert np.array_equal(examples[:4], _animation.random_examples(rig, 4, rig_seed=0, scan_seed=0)[:4])
    frames = _animation.source_frames(rig, 5, rig_seed=0)
    active = frames[frames != 0]
    assert frames.shape == (5, rig.n_shapes) and active.min() >= 0.2 and active.max() <= 1.0
    assert not np.array_equal(frames, _animation.source_frames(rig, 5, rig_seed=1))


def test_random_examples_replace_the_sequence_whatever_the_solver():
    cell = spec(examples="random")
    greedy = [row["rms"] for row in transfer_rows(cell)]
    cpsat = [row["rms"] for row in transfer_rows(replace(cell, solver="cpsat"))]
    ideal = [row["rms"] for row in transfer_rows(replace(cell, examples="ideal"))]
    assert greedy == cpsat and greedy != ideal and [row["j"] for row in transfer_rows(cell)] == [2, 4]


@pytest.mark.parametrize("method", ["ebfr", "anacondar[missing=off,anacon=off]"])
def test_frames_are_judged_by_their_mean_vertex_error(method):
    cell = spec(examples="random", frames=3, transfers=(method,), j_values=(4,))
    (row,) = transfer_rows(cell)
    template = rigs.generate("tiny")
    target = rigs.warp(template, cell.warp)
    weights = _animation.random_examples(template, 4, 0, cell.scan_seed)
    examples = transfer.training_expressions(target, weights)
    frames = _animation.source_frames(template, 3, 0)
    name, settings = harness.split_label(method)
    rig = transfer.get(name, **dict(settings))(template, target.neutral, weights, examples)
    expected = _animation.mean_vertex_error(
        np.tensordot(frames, rig, axes=1), np.tensordot(frames, target.deltas, axes=1)
    )
    assert "rms" not in row and row["frames_l2"] == pytest.approx(expected, rel=1e-9)


def test_the_fig10_preset_packs_and_draws_on_the_papers_rigs_over_five_faces():
    config = harness.RunConfig(preset="fig10", **harness.PRESETS["fig10"])
    cells = config.cells()
    assert len(cells) == 4 * 5 * (2 + 1) and {cell.frames for cell in cells} == {5}
    assert {cell.solver for cell in cells if cell.examples == "random"} == {"cpsat"}
    assert {cell.examples for cell in cells} == {"random", "ideal"} and set(config.seed) == set(range(5))
    assert "frames" not in cells[0].record_fields() and cells[0].id != replace(cells[0], frames=0).id
