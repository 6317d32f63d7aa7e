"""Validation of the `Rig` value: shapes, finiteness, index ranges, names, regions, faces; messages."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from hypothesis.extra import numpy as hnp

import rigs
from rigs import Rig, RigError, _rig as rig_module

SQUARE = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
TRIANGLES = np.array([[0, 1, 2], [0, 2, 3]])


def square_rig(**changes) -> Rig:
    deltas = np.zeros((2, 4, 3))
    deltas[0, 2] = [0.0, 0.0, 0.5]
    deltas[1, 0] = [0.0, -0.2, 0.0]
    values = dict(
        neutral=SQUARE,
        deltas=deltas,
        triangles=TRIANGLES,
        names=("up", "down"),
        regions={"corner": [2]},
        provenance=rigs.Provenance(source="square.npz"),
    )
    values.update(changes)
    return Rig(**values)


def test_valid_rig_has_sizes_and_frozen_read_only_arrays():
    rig = square_rig()
    assert (rig.n_vertices, rig.n_shapes, rig.n_triangles) == (4, 2, 2)
    assert rig.neutral.dtype == np.float64 and rig.triangles.dtype == np.int64
    for array in (rig.neutral, rig.deltas, rig.triangles, rig.regions["corner"]):
        assert not array.flags.writeable
    with pytest.raises(dataclasses.FrozenInstanceError):
        rig.names = ("x", "y")
    np.testing.assert_array_equal(rig.shape("up")[2], [1.0, 1.0, 0.5])
    assert rig.diagonal() == pytest.approx(np.sqrt(2.0))


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"neutral": SQUARE[:, :2]}, "square.npz: neutral must have shape (N, 3), got (4, 2)"),
        (
            {"neutral": np.zeros((0, 3)), "deltas": np.zeros((0, 0, 3)), "names": ()},
            "neutral has no vertices",
        ),
        (
            {"deltas": np.zeros((2, 3, 3))},
            "deltas must have shape (K, 4, 3) to match the neutral, got (2, 3, 3)",
        ),
        ({"names": ("up",)}, "square.npz: 1 names for 2 blendshapes"),
        ({"names": ("up", "up")}, "square.npz: duplicate blendshape name 'up'"),
        ({"names": ("up", "")}, "square.npz: a blendshape has an empty name"),
        ({"triangles": np.array([[0, 1, 2], [0, 2, 9]])}, "triangle 1 [0, 2, 9] indexes outside 0..3"),
        ({"triangles": np.array([[0, -1, 2]])}, "triangle 0 [0, -1, 2] indexes outside 0..3"),
        ({"triangles": np.array([[0, 1, 2, 3]])}, "triangles must have shape (T, 3), got (1, 4)"),
        ({"triangles": np.array([[0.0, 1.5, 2.0]])}, "triangles must hold integer vertex indices"),
        ({"regions": {"lip": [1, 4]}}, "square.npz: region 'lip' indexes outside 0..3"),
        ({"regions": {"lip": np.array([True, False])}}, "region 'lip' mask has shape (2,)"),
        ({"faces": (np.array([0, 1]),)}, "face 0 [0, 1] is not a polygon of this mesh"),
        ({"faces": (np.array([0, 1, 2, 7]),)}, "face 0 [0, 1, 2, 7] is not a polygon of this mesh"),
        ({"landmarks": {"nose": [0.5, 0.5]}}, "square.npz: landmark 'nose' must have shape (3,), got (2,)"),
        ({"landmarks": {"nose": [0.5, np.nan, 0.0]}}, "landmark 'nose' has a non-finite coordinate"),
        ({"provenance": {"source": "x.npz"}}, "rig: provenance must be a Provenance, got dict"),
        ({"load_report": {"empty_shapes": []}}, "load_report must be a LoadReport or None, got dict"),
    ],
)
def test_invalid_rig_names_field_and_value(changes, message):
    with pytest.raises(RigError) as caught:
        square_rig(**changes)
    assert message in str(caught.value)
    assert "\n" not in str(caught.value)


def test_non_finite_values_name_the_vertex_and_shape():
    neutral = SQUARE.copy()
    neutral[3, 1] = np.nan
    with pytest.raises(RigError, match=r"square.npz: neutral has a non-finite coordinate at vertex 3"):
        square_rig(neutral=neutral)
    deltas = np.zeros((2, 4, 3))
    deltas[1, 2, 0] = np.inf
    with pytest.raises(RigError, match=r"blendshape 'down' has a non-finite displacement at vertex 2"):
        square_rig(deltas=deltas)


def test_empty_blendshape_and_degenerate_triangle_are_allowed_and_reported():
    neutral = np.vstack([SQUARE, [[2.0, 0.0, 0.0]]])
    triangles = np.array([[0, 1, 2], [0, 2, 3], [0, 1, 4]])
    rig = Rig(neutral=neutral, deltas=np.zeros((1, 5, 3)), triangles=triangles, names=("idle",))
    assert rig.n_shapes == 1 and not rig.deltas.any()
    np.testing.assert_array_equal(rig.degenerate_triangles(), [2])


def test_regions_accept_masks_and_are_sorted_unique():
    rig = square_rig(regions={"mask": np.array([False, True, True, False]), "list": [3, 0, 3]})
    np.testing.assert_array_equal(rig.regions["mask"], [1, 2])
    np.testing.assert_array_equal(rig.regions["list"], [0, 3])


def test_replace_revalidates():
    rig = square_rig()
    with pytest.raises(RigError, match="duplicate blendshape name 'up'"):
        dataclasses.replace(rig, names=("up", "up"))


def test_index_suggests_close_names():
    with pytest.raises(RigError, match=r"no blendshape named 'upp' \(did you mean up\?\)"):
        square_rig().index("upp")


@settings(max_examples=40, deadline=None)
@given(
    n_vertices=st.integers(3, 12),
    n_shapes=st.integers(0, 5),
    seed=st.integers(0, 2**16),
)
def test_random_valid_rigs_construct_and_subset_keeps_values(n_vertices, n_shapes, seed):
    generator = np.random.default_rng(seed)
    neutral = generator.normal(size=(n_vertices, 3))
    deltas = generator.normal(size=(n_shapes, n_vertices, 3))
    triangles = generator.integers(0, n_vertices, size=(5, 3))
    names = tuple(f"shape{k}" for k in range(n_shapes))
    rig = Rig(neutral=neutral, deltas=deltas, triangles=triangles, names=names)
    reordered = rig.subset(names[::-1])
    np.testing.assert_array_equal(reordered.deltas, deltas[::-1])
    assert reordered.names == names[::-1]


@pytest.mark.parametrize("shape", [(3,), (0, 3), (7, 3), (5, 7, 3), (3, 400_000, 3), (1, 1_100_000, 3)])
def test_vector_lengths_are_the_same_on_any_number_of_threads(monkeypatch, shape) -> None:
    """Large arrays are split over threads (forced to three here); every length is bit for bit the one of a
    single pass and of the squares summed as ``(x x + z z) + y y`` (on any machine, where ``einsum``'s order
    follows the CPU's vector width and the memory layout), for contiguous vectors or not."""
    vectors = np.random.default_rng(0).normal(size=shape)
    monkeypatch.setattr(rig_module, "_usable_cpus", lambda: 1)
    layouts = {"contiguous": vectors, "reversed": vectors[..., ::-1]}
    single = {name: rigs.vector_lengths(layout) for name, layout in layouts.items()}
    monkeypatch.setattr(rig_module, "_usable_cpus", lambda: 3)
    for name, layout in layouts.items():
        assert np.array_equal(rigs.vector_lengths(layout), single[name]), name
    for name, layout in layouts.items():
        x, y, z = (layout[..., d] for d in range(3))
        assert np.array_equal(single[name], np.sqrt((x * x + z * z) + y * y)), name
    assert single["contiguous"].shape == shape[:-1]


@given(hnp.arrays(np.float64, st.tuples(st.integers(1, 50), st.integers(1, 4)), elements=st.floats(-9, 9)))
def test_bounding_box_is_the_columnwise_extent(points: np.ndarray) -> None:
    low, high = rigs.bounding_box(points)
    assert np.array_equal(low, points.min(axis=0)) and np.array_equal(high, points.max(axis=0))


def test_records_ride_along_when_a_rig_is_derived():
    truth = rigs.Truth(mirror_pairs=(("up", "down"),))
    rig = square_rig(landmarks={"nose": np.array([0.5, 0.5, 0.1])}, truth=truth)
    assert rig.landmarks == {"nose": (0.5, 0.5, 0.1)}
    derived = rig.subset(["down"])
    assert derived.provenance.source == "square.npz" and derived.truth is truth
    assert derived.landmarks == rig.landmarks and derived.surface is None and derived.load_report is None
    assert "source='square.npz'" in repr(derived)


def test_a_surface_holds_an_obj_file_or_a_gltf_surface():
    with pytest.raises(ValueError, match="either an OBJ file or a glTF surface"):
        rigs.Surface()


@pytest.mark.parametrize("shape", [(), (2,), (5, 4), (3, 2, 2)])
def test_vector_lengths_refuse_anything_but_three_vectors(shape) -> None:
    with pytest.raises(ValueError, match=r"3-vectors"):
        rigs.vector_lengths(np.ones(shape))
