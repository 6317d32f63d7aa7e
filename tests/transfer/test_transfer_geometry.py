"""Frames, the vertex solve and the patch layout."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import scipy.sparse as sp
from hypothesis import given, settings, strategies as st
from scipy.sparse.csgraph import connected_components

import transfer
from transfer._frames import TransferredEdges, edge_vectors, frames, rigid_rotation
from transfer._patches import blend_weights, edge_graph, partition
from transfer._reconstruct import FrameReconstruction


def test_frames_have_edges_and_the_scaled_normal():
    positions = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]])
    frame = frames(positions, np.array([[0, 1, 2]]))[0]
    np.testing.assert_allclose(frame[:, 0], [2.0, 0.0, 0.0])
    np.testing.assert_allclose(frame[:, 1], [0.0, 2.0, 0.0])
    np.testing.assert_allclose(frame[:, 2], [0.0, 0.0, 2.0])  # |n| = 4, scaled to sqrt(4)


def test_rigid_rotation_recovers_a_rotation():
    rng = np.random.default_rng(3)
    points = rng.normal(size=(30, 3))
    rotation, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    rotation *= np.sign(np.linalg.det(rotation))
    np.testing.assert_allclose(rigid_rotation(points, points @ rotation.T + 5.0), rotation, atol=1e-12)


def cotangent_laplacian(neutral: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """The textbook cotangent Laplacian: edge (i, j) weighs half the cotangents of its opposite angles."""
    laplacian = np.zeros((neutral.shape[0],) * 2)
    for corner in range(3):
        i, j, k = (triangles[:, (corner + shift) % 3] for shift in range(3))
        u, v = neutral[i] - neutral[k], neutral[j] - neutral[k]
        cotangent = np.einsum("ij,ij->i", u, v) / np.linalg.norm(np.cross(u, v), axis=1)
        np.add.at(laplacian, (i, j), -0.5 * cotangent)
        np.add.at(laplacian, (j, i), -0.5 * cotangent)
        np.add.at(laplacian, (i, i), 0.5 * cotangent)
        np.add.at(laplacian, (j, j), 0.5 * cotangent)
    return laplacian


def test_normal_matrix_is_the_cotangent_laplacian(sheet, bulge):
    rig = sheet(9, 10, 1)
    neutral = bulge(rig.neutral)  # obtuse and skewed triangles
    solver = FrameReconstruction(neutral, rig.triangles)
    np.testing.assert_allclose(
        solver.laplacian.toarray(), cotangent_laplacian(neutral, rig.triangles), atol=1e-12
    )


def reconstructed(solver: FrameReconstruction, edges: np.ndarray, fixed: np.ndarray, field: np.ndarray):
    """``(K, N, 3)`` shapes from ``(T, 2, 3, K)`` edge targets, each solved on its own free block."""
    result = field.copy()
    for k, mask in enumerate(fixed):
        block = solver.block(mask)
        if block is not None:
            held = field[k, block.near][..., None]
            result[k, block.free] = block.solve(edges[block.faces][..., [k]], held)[..., 0]
    return result


def test_reconstruction_recovers_a_field_from_its_own_edges(sheet):
    rig = sheet(12, 14, 3)
    field = rig.deltas
    solver = FrameReconstruction(rig.neutral * [1.0, 2.0, 0.5], rig.triangles)
    fixed = solver.constraints(field, 1e-6)
    edges = np.moveaxis(np.stack([edge_vectors(shape, rig.triangles) for shape in field]), 0, -1)
    np.testing.assert_allclose(reconstructed(solver, edges, fixed, field), field, atol=1e-12)


def test_reconstruction_anchors_every_separate_part(sheet):
    rig = sheet(6, 7, 2)
    n_vertices = rig.n_vertices
    neutral = np.r_[rig.neutral, rig.neutral + [3.0, 0.0, 0.0]]
    triangles = np.r_[rig.triangles, rig.triangles + n_vertices]
    field = np.r_[rig.neutral**2, rig.neutral**2 + [1.0, -2.0, 0.5]][None]  # no static vertex at all
    solver = FrameReconstruction(neutral, triangles)
    fixed = solver.constraints(field, 0.0)
    assert fixed[0, :n_vertices].sum() == 1 and fixed[0, n_vertices:].sum() == 1
    edges = edge_vectors(field[0], triangles)[..., None]
    np.testing.assert_allclose(reconstructed(solver, edges, fixed, field), field, atol=1e-12)


@settings(max_examples=30, deadline=None)
@given(
    n_columns=st.integers(3, 9),
    n_rows=st.integers(3, 9),
    held_share=st.floats(0.05, 0.95),
    seed=st.integers(0, 2**16),
)
def test_a_free_block_solves_the_dense_least_squares(
    sheet, bulge, dense_reconstruction, n_columns, n_rows, held_share, seed
):
    """Only the triangles around the free vertices are read, and the answer is the whole mesh's."""
    rig = sheet(n_columns, n_rows, 1, seed)
    neutral = bulge(rig.neutral)
    rng = np.random.default_rng(seed)
    fixed = rng.random(rig.n_vertices) < held_share
    fixed[rng.integers(rig.n_vertices)] = True
    values = rng.normal(size=(rig.n_vertices, 3))
    edges = rng.normal(size=(rig.triangles.shape[0], 2, 3))
    solver = FrameReconstruction(neutral, rig.triangles, factor_budget=10**6)
    block = solver.block(fixed)
    if fixed.all():
        assert block is None
        return
    touching = np.isin(rig.triangles, block.free).any(axis=1)
    assert np.array_equal(block.faces, np.flatnonzero(touching))
    assert solver.block(fixed) is block  # kept within the budget
    expected = dense_reconstruction(neutral, rig.triangles, edges, fixed, values)
    found = block.solve(edges[block.faces][..., None], values[block.near][..., None])[..., 0]
    np.testing.assert_allclose(found, expected[~fixed], rtol=0, atol=1e-10 * np.abs(expected).max())


@settings(max_examples=20, deadline=None)
@given(n_shapes=st.integers(1, 4), seed=st.integers(0, 2**16))
def test_transferred_edges_apply_each_deformation_gradient_to_the_target(
    sheet, bulge, plain_frames, n_shapes, seed
):
    """``M_k^{A*} = (M(A0 + A_k) M(A0)^-1 - I) E_B`` (Li et al. 2010, sec. 3A) on any triangles and shapes."""
    rig = sheet(7, 8, n_shapes, seed)
    target = bulge(rig.neutral)
    prior = TransferredEdges(rig.neutral, rig.deltas, target, rig.triangles)
    rng = np.random.default_rng(seed)
    faces = np.sort(rng.choice(rig.triangles.shape[0], 20, replace=False))
    shapes = rng.permutation(n_shapes)
    found = prior.block(faces, shapes)
    inverse = np.linalg.inv(plain_frames(rig.neutral, rig.triangles[faces]))
    target_edges = plain_frames(target, rig.triangles[faces])[:, :, :2]
    for column, k in enumerate(shapes):
        gradient = plain_frames(rig.neutral + rig.deltas[k], rig.triangles[faces]) @ inverse
        expected = ((gradient - np.eye(3)) @ target_edges).transpose(0, 2, 1)
        np.testing.assert_allclose(
            found[..., column], expected, rtol=0, atol=1e-12 * np.abs(target_edges).max()
        )


def test_each_shapes_targets_are_evaluated_once_for_every_block(sheet, bulge, monkeypatch):
    """Blocks of any triangles gather what each shape's targets and motion on all its triangles keep."""
    rig = sheet(9, 10, 4, 3)
    prior = TransferredEdges(rig.neutral, rig.deltas, bulge(rig.neutral), rig.triangles)
    plain = TransferredEdges(rig.neutral, rig.deltas, bulge(rig.neutral), rig.triangles)
    evaluated: list[int] = []
    edges = prior.edges

    def counted(faces: np.ndarray, shape: int) -> np.ndarray:
        evaluated.append(shape)
        return edges(faces, shape)

    monkeypatch.setattr(prior, "edges", counted)
    rng = np.random.default_rng(3)
    for _ in range(5):
        faces = np.sort(rng.choice(rig.triangles.shape[0], 60, replace=False))
        shapes = rng.permutation(4)[:3]
        found = prior.block(faces, shapes)
        for column, k in enumerate(shapes):
            rows = np.isin(faces, plain.moving(k))
            assert np.array_equal(found[rows, ..., column], plain.edges(faces[rows], k))
            assert not found[~rows, ..., column].any()
    assert sorted(evaluated) == sorted(set(evaluated))
    for k in range(4):
        moved = plain.moved(plain.moving(k), k)
        assert np.array_equal(prior.on_moving(k)[1], np.sqrt(np.sum(moved**2, axis=(1, 2))))


def test_degenerate_triangles_do_not_break_the_transfer(sheet):
    rig = sheet(8, 9, 3)
    neutral = np.r_[rig.neutral, rig.neutral[:1]]  # a duplicated vertex makes a zero-area triangle
    triangles = np.r_[rig.triangles, [[0, 1, rig.n_vertices]]]
    deltas = np.concatenate([rig.deltas, rig.deltas[:, :1]], axis=1)
    broken = replace(rig, neutral=neutral, triangles=triangles, deltas=deltas)
    assert broken.degenerate_triangles().size == 1
    target = replace(broken, neutral=broken.neutral * 1.2, deltas=broken.deltas * 1.2)
    result = transfer.get("dt")(broken, target.neutral)
    assert np.isfinite(result).all()
    # The duplicate touches only the zero-area triangle: nothing constrains it, it keeps the template's
    # displacement. Every other vertex is exact up to the near-static ones held the same way.
    np.testing.assert_allclose(result[:, -1], broken.deltas[:, -1], atol=1e-15)
    error = transfer.rms(result[:, :-1], target.deltas[:, :-1])
    assert error <= 1e-5 * transfer.rms(np.zeros_like(result), target.deltas)


def test_partition_gives_connected_compact_patches(sheet):
    rig = sheet(40, 44, 1)
    labels = partition(rig.neutral, rig.triangles, 80)
    assert labels.shape == (rig.n_vertices,)
    n_patches = labels.max() + 1
    assert 70 <= n_patches <= 80
    edges = edge_graph(rig.neutral, rig.triangles).tocoo()
    inside = labels[edges.row] == labels[edges.col]
    same = sp.csr_matrix((edges.data[inside], (edges.row[inside], edges.col[inside])), shape=edges.shape)
    n_parts, _ = connected_components(same, directed=False)
    assert n_parts == n_patches  # every patch is one connected piece
    sizes = np.bincount(labels)
    assert sizes.max() <= 4 * sizes.mean()
    assert np.array_equal(labels, partition(rig.neutral, rig.triangles, 80))


def test_partition_covers_separate_parts(sheet):
    rig = sheet(6, 7, 1)
    neutral = np.r_[rig.neutral, rig.neutral + [5.0, 0.0, 0.0]]
    triangles = np.r_[rig.triangles, rig.triangles + rig.n_vertices]
    labels = partition(neutral, triangles, 1)
    assert labels.min() == 0 and labels.max() == 1
    assert len(set(labels[: rig.n_vertices])) == 1 and len(set(labels[rig.n_vertices :])) == 1


def test_blend_weights_are_a_partition_of_unity_that_widens_with_rings(sheet):
    rig = sheet(20, 22, 1)
    labels = partition(rig.neutral, rig.triangles, 12)
    support = []
    for rings in (0, 1, 3):
        weights = blend_weights(labels, rig.triangles, rings)
        np.testing.assert_allclose(np.asarray(weights.sum(axis=1)).ravel(), 1.0)
        assert weights.min() >= 0
        support.append(weights.nnz)
    assert support[0] == rig.n_vertices
    assert support[0] < support[1] < support[2]
