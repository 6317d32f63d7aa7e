"""The fast shape-symmetry search (spatial-hash bounds, probing only the candidate pairs) against an
exhaustive evaluation of eqs. 9-10 over every pair of shapes, straight from the dense (K, N) definition, on
random face rigs, generated presets, a rig of the film layout and the Face Units rig."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

import packing._shape_symmetry as symmetry
import packing._symmetry_candidates as candidates
import packing._symmetry_field as symmetry_field
import rigs
from packing._binary import (
    active_entries,
    displacement_norms,
    empty_mask,
    entries,
    lengths_matrix,
    masks_from_norms,
    sparse_masks,
)


def exhaustive_shape_symmetry(deltas, norms, masks, mirror, normal, eligible, tol, max_overlap, axis):
    """Eqs. 9-10 for every (k, m) straight from the definition, then the same matching and overlap check."""
    n_shapes = len(deltas)
    reflection = np.eye(3) - 2.0 * np.outer(normal, normal)
    valid = mirror >= 0
    image = np.where(valid, mirror, 0)
    mirrored_masks = masks[:, image] & valid  # p(b_m)^n
    mirrored_moves = (deltas[:, image] @ reflection) * mirrored_masks[..., None]  # p(b_m)^n P_m^n
    own = deltas * masks[..., None]
    error = np.full((n_shapes, n_shapes), np.inf)
    for k in range(n_shapes):
        numerator = np.linalg.norm(own[k][None] - mirrored_moves, axis=2).sum(axis=1)
        overlap = (masks[k][None] & mirrored_masks).sum(axis=1)
        error[k, overlap > 0] = numerator[overlap > 0] / overlap[overlap > 0]
    largest = norms.max(axis=1)
    self_symmetric = eligible & (np.diag(error) < tol * largest)
    candidates = eligible & ~self_symmetric
    score = np.maximum(error, error.T)
    threshold = tol * np.minimum(largest[:, None], largest[None, :])
    passing = np.triu(score < threshold, k=1) & candidates[:, None] & candidates[None, :]
    first, second = np.nonzero(passing)
    matched = symmetry.match_pairs(first, second, score[first, second])
    if not matched:
        return [], self_symmetric, []
    share = symmetry._off_axis_overlap(sparse_masks(masks), np.array([pair[:2] for pair in matched]), axis)
    kept = share <= max_overlap
    pairs = [pair for pair, keep in zip(matched, kept, strict=True) if keep]
    spread = [(a, b, float(f)) for (a, b, _), f, keep in zip(matched, share, kept, strict=True) if not keep]
    return pairs, self_symmetric, spread


def inputs(rig: rigs.Rig, mu: float = 0.3):
    norms = displacement_norms(rig.deltas)
    empty = empty_mask(norms, 1e-6, rig.diagonal())
    masks = masks_from_norms(norms, mu, empty)
    mirror = rigs.mirror_map(rig.neutral)
    normal = symmetry.reflection_normal(rig.neutral, mirror)
    axis = symmetry.axis_distances(rig.neutral, mirror, normal)
    return norms, masks, mirror, normal, ~empty, axis


def assert_same(fast, reference, scale: float):
    """The same pairs with the same errors (up to rounding: exact mirror pairs have errors of rounding size,
    so their order is not compared), the same self-symmetric shapes and refused spread matches."""
    (pairs, self_symmetric, spread), (ref_pairs, ref_self, ref_spread) = fast, reference
    errors, ref_errors = ({(a, b): e for a, b, e in found} for found in (pairs, ref_pairs))
    assert errors.keys() == ref_errors.keys()
    for pair, error in errors.items():
        assert error == pytest.approx(ref_errors[pair], rel=1e-9, abs=1e-12 * scale)
    assert np.array_equal(self_symmetric, ref_self)
    assert {pair[:2] for pair in spread} == {pair[:2] for pair in ref_spread}


def random_face(kit, seed: int, n_bumps: int, jitter: float):
    """Bumps on the right half, their mirror images (some jittered, some moved), symmetric centre bumps."""
    rng = np.random.default_rng(seed)
    bumps = []
    for index in range(n_bumps):
        centre = (float(rng.uniform(0.1, 0.8)), float(rng.uniform(-0.8, 0.8)))
        radius = (float(rng.uniform(0.08, 0.3)), float(rng.uniform(0.08, 0.3)))
        direction = tuple(float(v) for v in rng.normal(size=3))
        bump = kit.Bump(f"s{index}_R", centre, radius, direction, float(rng.uniform(0.3, 1.5)))
        bumps.append(bump)
        kind = rng.integers(3)
        if kind == 0:  # an exact mirror pair
            bumps.append(kit.mirrored(bump, f"s{index}_L"))
        elif kind == 1:  # a near pair: moved a little
            moved = kit.mirrored(bump, f"s{index}_L")
            bumps.append(
                kit.Bump(moved.name, (moved.centre[0] - 0.05, moved.centre[1]), radius, direction, 1.0)
            )
    bumps.append(kit.Bump("centre", (0.0, float(rng.uniform(-0.5, 0.5))), (0.2, 0.1), (0.0, 1.0, 0.2)))
    return kit.face_rig(bumps, side=23, jitter=jitter, seed=seed)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    seed=st.integers(0, 10_000),
    n_bumps=st.integers(1, 9),
    jitter=st.sampled_from([0.0, 0.001, 0.02]),
    tol=st.sampled_from([0.2, 0.4, 0.8]),
    hashed=st.booleans(),
)
def test_fast_search_equals_the_exhaustive_one_on_random_faces(kit, seed, n_bumps, jitter, tol, hashed):
    rig = random_face(kit, seed, n_bumps, jitter)
    norms, masks, mirror, normal, eligible, axis = inputs(rig)
    reference = exhaustive_shape_symmetry(rig.deltas, norms, masks, mirror, normal, eligible, tol, 0.15, axis)
    fast = symmetry.shape_symmetry(
        rig.deltas, norms, masks, mirror, normal, eligible, tol, 0.15, axis, rig.neutral if hashed else None
    )
    assert_same(fast, reference, float(norms.max()))


#: The film layout (the Female face with many shapes) at a size the exhaustive reference can afford.
FILM_LAYOUT = replace(rigs.PRESETS["film"], name="film-small", n_vertices=2000, n_shapes=160)


def assert_equals_the_exhaustive_search(rig: rigs.Rig) -> None:
    norms, masks, mirror, normal, eligible, axis = inputs(rig)
    reference = exhaustive_shape_symmetry(rig.deltas, norms, masks, mirror, normal, eligible, 0.4, 0.15, axis)
    assert reference[0]  # (a rig without pairs would prove little)
    for lengths in (norms, lengths_matrix(norms, sparse_masks(masks))):  # dense or active-only lengths
        fast = symmetry.shape_symmetry(
            rig.deltas, lengths, sparse_masks(masks), mirror, normal, eligible, 0.4, 0.15, axis, rig.neutral
        )
        assert_same(fast, reference, float(norms.max()))


@pytest.mark.parametrize("preset", ["tiny", "arkit52", "male", FILM_LAYOUT])
def test_fast_search_equals_the_exhaustive_one_on_presets(preset):
    assert_equals_the_exhaustive_search(rigs.generate(preset))


def test_fast_search_equals_the_exhaustive_one_on_face_units(faceunits):
    assert_equals_the_exhaustive_search(faceunits)


def test_chunked_and_coarsened_search_finds_the_same_pairs(monkeypatch):
    """Tiny chunks, lookup tables of a few shapes and a grid coarsened to fit a tiny budget visit every
    branch of the search."""
    rig = rigs.generate("female")
    norms, masks, mirror, normal, eligible, axis = inputs(rig)
    arguments = (rig.deltas, norms, masks, mirror, normal, eligible, 0.4, 0.15, axis, rig.neutral)
    default = symmetry.shape_symmetry(*arguments)
    monkeypatch.setattr(symmetry, "PROBE_CHUNK", 1000)
    monkeypatch.setattr(candidates, "COMBO_CHUNK", 500)
    monkeypatch.setattr(candidates, "MAX_CELL_SUMS", 5 * rig.n_shapes)
    monkeypatch.setattr(candidates, "EXTENT_SAMPLE", 2)  # the cell side from a few shapes' extents
    monkeypatch.setattr(symmetry_field, "TABLE_CELLS", 3 * rig.n_vertices)
    chunked = symmetry.shape_symmetry(*arguments)
    assert [pair[:2] for pair in chunked[0]] == [pair[:2] for pair in default[0]]
    assert [pair[2] for pair in chunked[0]] == [pair[2] for pair in default[0]]  # the same sums, bit for bit
    assert np.array_equal(chunked[1], default[1]) and chunked[2] == default[2]


def test_image_entries_find_every_mirrored_active_entry():
    """The lookup of ``(m, mirror(n))`` among the active entries equals a dense (K, N) table's answer."""
    rig = rigs.generate("arkit52")
    norms, masks, mirror, normal, _, _ = inputs(rig)
    active = sparse_masks(masks)
    rows, cols = entries(active)
    field = symmetry_field.SymmetryField.of(rig.deltas, norms, active, rows, cols, normal)
    slot = np.full(masks.shape, -1)
    slot[rows, cols] = np.arange(rows.size)
    rng = np.random.default_rng(0)
    shapes = np.sort(rng.integers(0, rig.n_shapes, 5000))
    vertices = rng.integers(0, rig.n_vertices, shapes.size)
    expected = np.where(mirror[vertices] >= 0, slot[shapes, mirror[vertices]], -1)
    assert (expected >= 0).any() and (expected < 0).any()
    assert np.array_equal(field.image_entries(shapes, vertices, mirror), expected)


def test_candidate_bounds_keep_every_pair_below_the_threshold():
    """The per-cell bounds never rule out a pair whose exhaustive errors pass eq. 10 both ways."""
    rig = rigs.generate("digidouble")
    norms, masks, mirror, normal, eligible, axis = inputs(rig)
    active = sparse_masks(masks)
    rows, cols = entries(active)
    field = symmetry_field.SymmetryField.of(rig.deltas, norms, active, rows, cols, normal)
    largest = norms.max(axis=1)
    preimages = symmetry_field.Preimages.of(mirror, cols)
    cells, flip = candidates.vertex_cells(rig.neutral, active, cols, eligible, mirror, normal)
    shapes, image = candidates.cell_sums(field, rows, cols, preimages, eligible, cells, flip)
    found = candidates.candidate_pairs(field, rows, shapes, image, eligible, largest, 0.4, flip)
    kept = set(zip(found.first.tolist(), found.second.tolist(), strict=True))
    reference = exhaustive_shape_symmetry(rig.deltas, norms, masks, mirror, normal, eligible, 0.4, 1.0, axis)
    assert reference[0] and {(a, b) for a, b, _ in reference[0]} <= kept
    assert all((b, a) in kept for a, b in kept)  # both directions of eq. 10
    assert len(kept) < 0.2 * rig.n_shapes**2  # and it does rule out most pairs


def test_the_field_holds_the_displacements_of_the_active_entries():
    rig = rigs.generate("arkit52")
    norms, masks, mirror, normal, _, _ = inputs(rig)
    active = sparse_masks(masks)
    rows, cols = entries(active)
    field = symmetry_field.SymmetryField.of(rig.deltas, norms, active, rows, cols, normal)
    picked = np.random.default_rng(1).integers(0, rows.size, 300)
    assert np.array_equal(field.moved(picked), rig.deltas[rows[picked], cols[picked]])


@pytest.mark.parametrize("n_rows", [0, 1, 2, 3, 8191, 8192, 8193, 8194, 20000])
def test_reflecting_in_runs_of_rows_is_one_matrix_product_to_rounding(n_rows):
    """Equal to one product up to the rounding of a three-term sum: BLAS kernels may order the sum
    differently for a run's last rows (on this machine they do not, elsewhere they may)."""
    rng = np.random.default_rng(n_rows)
    vectors = rng.normal(size=(n_rows, 3)) * rng.uniform(0, 4, size=(n_rows, 1))
    normal = rng.normal(size=3)
    normal /= np.linalg.norm(normal)
    reflection = np.eye(3) - 2.0 * np.outer(normal, normal)
    whole = vectors @ reflection
    bound = 4 * np.finfo(float).eps * np.abs(vectors).sum(axis=1, keepdims=True)
    assert np.all(np.abs(symmetry_field.reflect(vectors, reflection) - whole) <= bound)


def test_displacements_gathered_with_the_masks_give_the_same_pairs_bit_for_bit():
    """`analyse` hands the symmetry step the active displacements it gathered with the masks (`moved`):
    the pairs, their errors and the refused matches are those of gathering them again."""
    rig = rigs.generate("digidouble")
    _, masks, mirror, normal, eligible, axis = inputs(rig)
    norms, _, active, moved = active_entries(rig.deltas, 0.3, 1e-6, rig.diagonal(), gather=True)
    arguments = (rig.deltas, norms, active.toarray(), mirror, normal, eligible, 0.4, 0.15, axis, rig.neutral)
    gathered = symmetry.shape_symmetry(*arguments)
    given = moved.copy()
    given_moved = symmetry.shape_symmetry(*arguments, moved=given)
    assert gathered[0] and given_moved[0] == gathered[0] and given_moved[2] == gathered[2]
    assert np.array_equal(given, moved)  # read, not changed
    assert np.array_equal(given_moved[1], gathered[1])


@pytest.mark.parametrize(
    "wrong",
    [lambda m: m[:-1], lambda m: m.astype(np.float32), lambda m: m[:, :2]],
    ids=["short", "float32", "two-columns"],
)
def test_given_displacements_of_another_shape_type_or_layout_are_refused(wrong):
    rig = rigs.generate("arkit52")
    norms, _, active, moved = active_entries(rig.deltas, 0.3, 1e-6, rig.diagonal(), gather=True)
    rows, cols = entries(active)
    _, _, _, normal, _, _ = inputs(rig)
    with pytest.raises(ValueError, match=r"moved must be the \(\d+, 3\) float64"):
        symmetry_field.SymmetryField.of(rig.deltas, norms, active, rows, cols, normal, wrong(moved))
