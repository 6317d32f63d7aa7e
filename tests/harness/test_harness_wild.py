"""`harness pack`, `rigs info` and `run` on rigs from the wild: other units, empty and noise-only shapes,
asymmetric captures, rigs without regions, OBJ folders, and the Face Units rig when it can be had."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

import rigs
from tests.harness.cli_helpers import assert_one_line_error, flat, invoke, pack


@pytest.fixture(scope="module")
def tiny() -> rigs.Rig:
    return rigs.generate("tiny")


def _smooth_asymmetry(points: np.ndarray, amplitude: float, seed: int) -> np.ndarray:
    """A smooth displacement field with no left/right symmetry (a few Gaussian bumps)."""
    generator = np.random.default_rng(seed)
    low, high = points.min(axis=0), points.max(axis=0)
    span = float((high - low).max())
    field = np.zeros_like(points)
    for _ in range(6):
        centre = low + generator.random(3) * (high - low)
        weight = np.exp(-np.sum((points - centre) ** 2, axis=1) / (0.3 * span) ** 2)
        field += amplitude * span * generator.normal(size=3) * weight[:, None]
    return field


def test_pack_result_does_not_depend_on_the_length_unit(tiny, tmp_path) -> None:
    documents = []
    for unit, factor in (("m", 0.01), ("mm", 10.0)):
        scaled = replace(tiny, neutral=tiny.neutral * factor, deltas=tiny.deltas * factor)
        documents.append(pack(rigs.save(scaled, tmp_path / f"{unit}.npz"), tmp_path / unit)[0])
    folder = rigs.save(
        replace(tiny, neutral=tiny.neutral * 0.01, deltas=tiny.deltas * 0.01), tmp_path / "obj"
    )
    documents.append(pack(folder, tmp_path / "obj-out")[0])
    reference = documents[0]
    for document in documents[1:]:
        assert [e["shapes"] for e in document["expressions"]] == [
            e["shapes"] for e in reference["expressions"]
        ]
        assert sorted(document["pairs"]) == sorted(reference["pairs"])  # equal-error pairs: any order
        assert [e["objective"] for e in document["expressions"]] == pytest.approx(
            [e["objective"] for e in reference["expressions"]], rel=1e-9
        )


def test_empty_and_noise_only_shapes_are_reported_and_never_packed(tiny, tmp_path) -> None:
    deltas = tiny.deltas.copy()
    deltas[0] = 0.0
    deltas[1] = np.random.default_rng(0).normal(scale=1e-12, size=deltas[1].shape)
    path = rigs.save(replace(tiny, deltas=deltas), tmp_path / "holes.npz")
    empty = list(tiny.names[:2])
    document, output = pack(path, tmp_path / "out")
    assert f"2 empty blendshapes excluded: {', '.join(empty)}" in output
    packed = {name for e in document["expressions"] for name in e["shapes"] + e["extra_examples"]}
    assert packed == set(tiny.names[2:])
    assert json.loads(invoke("rigs", "info", path, "--json").output)["empty_shapes"] == empty


def test_a_rig_whose_every_shape_is_empty_is_one_line_error(tiny, tmp_path) -> None:
    path = rigs.save(replace(tiny, deltas=np.zeros_like(tiny.deltas)), tmp_path / "flat.npz")
    assert_one_line_error(
        invoke("pack", path, "--out", tmp_path / "out"), str(path), "every one of its 12 blendshapes is empty"
    )


def test_asymmetric_capture_keeps_its_mirror_pairs(tiny, tmp_path) -> None:
    # The mirror map matches reflected vertices to the mirrored surface (rigs.mirror_map with triangles), so a
    # smoothly asymmetric capture keeps the mirror pairs of the symmetric rig.
    neutral = tiny.neutral + _smooth_asymmetry(tiny.neutral, 0.02, seed=1)
    capture = replace(
        tiny, neutral=neutral, regions={}, landmarks={}, provenance=rigs.Provenance(), truth=None
    )
    document, output = pack(rigs.save(capture, tmp_path / "capture.npz"), tmp_path / "out")
    mirror_pairs = {frozenset(pair) for pair in tiny.truth.mirror_pairs}
    assert mirror_pairs and {frozenset(pair) for pair in document["pairs"]} == mirror_pairs
    assert f"{len(document['pairs'])} symmetry pairs kept together" in output
    assert sorted(n for e in document["expressions"] for n in e["shapes"]) == sorted(tiny.names)


@pytest.mark.parametrize("count", [1, 2])
def test_rigs_with_one_or_two_shapes(tiny, tmp_path, count) -> None:
    names = ("jawOpen", "browInnerUp_L")[:count]
    document, _ = pack(rigs.save(tiny.subset(names), tmp_path / "few.npz"), tmp_path / "out")
    assert sorted(n for e in document["expressions"] for n in e["shapes"]) == sorted(names)
    assert len(list((tmp_path / "out").glob("expression_*.obj"))) == len(document["expressions"])


def test_a_warp_the_rig_file_has_no_regions_for_is_one_line_error_before_any_cell(tiny, tmp_path) -> None:
    path = rigs.save(
        replace(tiny, regions={}, landmarks={}, provenance=rigs.Provenance(), truth=None),
        tmp_path / "bare.npz",
    )
    out = tmp_path / "run"
    result = invoke("run", "--rigs", path, "--solvers", "cpsat,greedy", "--warps", "big-eyes", "--out", out)
    assert_one_line_error(
        result,
        f"--warps big-eyes: {path}: cannot locate 'eye_L' for the warp",
        "give the centre as coordinates [x, y, z]",  # brackets survive the terminal's markup
        "warps that apply to this rig: character, scale-x0.8, scale-x0.8+character, scale-x1.3,",
    )
    assert not out.exists()


def test_an_unreadable_rig_file_stops_the_run_before_any_cell(tmp_path) -> None:
    path = tmp_path / "face.npz"
    path.write_bytes(b"truncated")
    out = tmp_path / "run"
    assert_one_line_error(
        invoke("run", "--rigs", path, "--warps", "none", "--out", out), f"{path}: not a NumPy"
    )
    assert not out.exists()


def test_a_rig_file_with_regions_runs_with_a_warp(tiny, tmp_path) -> None:
    path = rigs.save(tiny, tmp_path / "tiny.npz")
    result = invoke(
        "run", "--rigs", path, "--solvers", "greedy", "--transfers", "delta", "--warps", "big-eyes",
        "--jobs", "1", "--out", tmp_path / "run", "-q",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "ok 1" in flat(result.output)


def test_pack_reads_the_neutral_obj_path_and_a_target_with_tabs_and_crlf(tiny, tmp_path) -> None:
    folder = rigs.save(tiny, tmp_path / "face")
    wider = tiny.neutral * [1.2, 1.0, 1.0]
    lines = ["# scanned actor", "o actor"]
    lines += [f"  v\t{x!r}\t{y!r}\t{z!r}  # vertex" for x, y, z in wider.tolist()]
    lines += ["vn 0 0 1"] + [f"f {a + 1}//1 {b + 1}//1 {c + 1}//1" for a, b, c in tiny.triangles.tolist()]
    target = tmp_path / "actor.obj"
    target.write_bytes("\r\n".join(lines).encode())
    document, output = pack(folder / "neutral.obj", tmp_path / "out", "--target", target)
    assert "no target neutral" not in output
    assert sorted(n for e in document["expressions"] for n in e["shapes"]) == sorted(tiny.names)


@pytest.fixture(scope="module")
def faceunits() -> rigs.Rig:
    try:
        return rigs.load_faceunits(download=False)
    except rigs.RigError as error:
        pytest.skip(f"Face Units rig not in the user cache (run `harness rigs fetch faceunits`): {error}")


def test_faceunits_packs_with_its_mirror_pairs_and_takes_eye_warps(faceunits, tmp_path) -> None:
    path = rigs.save(faceunits, tmp_path / "faceunits.npz")
    document, output = pack(path, tmp_path / "out", "--no-default-constraints")  # the geometry's pairs alone
    assert len(document["pairs"]) >= 15
    # sec. 4.4.1: shapes spread over both halves are no pair (they would cancel in one expression)
    assert {("jawLeft", "jawRight"), ("mouthLeft", "mouthRight")}.isdisjoint(map(tuple, document["pairs"]))
    assert document["warnings"] == []  # no expression holds shapes that cancel
    for left, right in document["pairs"]:
        assert {left.removesuffix("Left"), right.removesuffix("Right")} in ({left[:-4]}, {right[:-5]})
    assert sorted(n for e in document["expressions"] for n in e["shapes"]) == sorted(faceunits.names)
    assert "empty" not in output
    result = invoke("run", "--rigs", path, "--warps", "big-eyes,alien", "--out", tmp_path / "run")
    assert_one_line_error(
        result,
        "--warps alien:",
        "cannot locate 'mouth'",
        "big-eyes, big-eyes+character, character, scale-x0.8",
    )


def test_stray_vertices_and_degenerate_triangles_are_reported_and_change_no_pair(tiny, tmp_path) -> None:
    n = tiny.n_vertices
    strays = tiny.neutral[:2] + [300.0, 0.0, 0.0]  # exporter leftovers far off to one side
    rig = replace(
        tiny,
        neutral=np.concatenate([tiny.neutral, strays]),
        deltas=np.concatenate([tiny.deltas, np.zeros((tiny.n_shapes, 2, 3))], axis=1),
        triangles=np.concatenate([tiny.triangles, [[0, 0, 1]]]),
    )
    path = rigs.save(rig, tmp_path / "strays.npz")
    summary = json.loads(invoke("rigs", "info", path, "--json").output)
    assert summary["unreferenced_vertices"] == 2 and summary["degenerate_triangles"] == 1
    reference, _ = pack(rigs.save(tiny, tmp_path / "tiny.npz"), tmp_path / "reference")
    document, output = pack(path, tmp_path / "out")
    assert sorted(document["pairs"]) == sorted(reference["pairs"])
    assert f"2 of {n + 2} vertices have no mirror vertex" in output


def test_shapes_left_out_are_named_with_the_reason(tiny, tmp_path) -> None:
    path = rigs.save(tiny.subset(["jawOpen"]), tmp_path / "one.npz")
    document, output = pack(path, tmp_path / "rejected", "--reject", "1:jawOpen")
    assert document["expressions"] == [] and not list((tmp_path / "rejected").glob("expression_*.obj"))
    assert "1 blendshapes in no expression (every shape proposed for expression 1 was rejected" in output
    document, output = pack(rigs.save(tiny, tmp_path / "tiny.npz"), tmp_path / "short", "--jmax", "1")
    missing = sorted(set(tiny.names) - set(document["expressions"][0]["shapes"]))
    assert f"{len(missing)} blendshapes in no expression (--jmax 1 reached): " in output
    assert all(name in output for name in missing)


def test_rigs_info_counts_the_shapes_that_move_every_vertex(tiny, tmp_path) -> None:
    noise = np.random.default_rng(0).normal(scale=1e-3 * tiny.diagonal(), size=tiny.deltas.shape)
    path = rigs.save(replace(tiny, deltas=tiny.deltas + noise), tmp_path / "noisy.npz")
    result = invoke("rigs", "info", path, "--json")
    assert result.exit_code == 0, result.output
    summary = json.loads(result.output[result.output.index("{") :])
    assert summary["shapes_moving_every_vertex"] == tiny.n_shapes
    assert summary["noise_floor"] == "none (displacements read as written)"
    clean = json.loads(invoke("rigs", "info", rigs.save(tiny, tmp_path / "clean.npz"), "--json").output)
    assert clean["shapes_moving_every_vertex"] == 0
