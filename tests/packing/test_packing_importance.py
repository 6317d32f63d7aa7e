"""Binary blendshapes (eq. 2) and importance (eqs. 4-8) against hand-computed values on a 2-triangle rig."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import packing
import rigs
from packing._importance import DegenerateDistortionWarning, triangle_distortion
from registry import HarnessError
from rigs import Rig, RigError

# Unit square in the z = 0 plane, split into triangles (0, 1, 2) and (1, 3, 2).
#   2 --- 3
#   |  \  |
#   0 --- 1
SQUARE = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]])
TRIANGLES = np.array([[0, 1, 2], [1, 3, 2]])
STRETCHED = SQUARE * [2.0, 1.0, 1.0]  # the target neutral: x doubled


def _moves(*moves: tuple[int, tuple[float, float, float]]) -> np.ndarray:
    delta = np.zeros((4, 3))
    for vertex, displacement in moves:
        delta[vertex] = displacement
    return delta


SHAPES = {
    "A": _moves((0, (0, 0, 1.0)), (1, (0, 0, 0.2))),  # active {0}: 0.2 < 0.3 * 1
    "B": _moves((2, (0, 0, 0.4)), (3, (0, 0, 0.5))),  # active {2, 3}
    "C": _moves((0, (0, 0, 2.0))),  # active {0}, nearly parallel to A
    "D": _moves((0, (0, 0, -1.0))),  # active {0}, opposite to A and C
    "E": _moves(),  # empty
}


@pytest.fixture
def square() -> Rig:
    return Rig(
        SQUARE,
        np.array(list(SHAPES.values())),
        TRIANGLES,
        tuple(SHAPES),
        provenance=rigs.Provenance(source="square"),
    )


# Hand computation --------------------------------------------------------------------------------------
# Eq. 6, v = second vertex. Triangle (0, 1, 2): |vu| = |p0 - p1| 1 -> 2; |vw| = |p2 - p1| sqrt 2 -> sqrt 5.
S_T0 = max(1 / 2, 2 / 1) + max(math.sqrt(2) / math.sqrt(5), math.sqrt(5) / math.sqrt(2))
# Triangle (1, 3, 2): |vu| = |p1 - p3| 1 -> 1; |vw| = |p2 - p3| 1 -> 2.
S_T1 = max(1.0, 1.0) + max(1 / 2, 2 / 1)
# Eq. 5: mean active displacement.
MEAN = {"A": 1.0, "B": (0.4 + 0.5) / 2, "C": 2.0, "D": 1.0, "E": 0.0}
# Eq. 7: A, C, D touch triangle 0 (vertex 0); B touches both (vertices 2 and 3).
SUM_S = {"A": S_T0, "B": S_T0 + S_T1, "C": S_T0, "D": S_T0, "E": 0.0}
COS_CA = 2.0 / (math.sqrt(1.0**2 + 0.2**2) * 2.0)


def _expected(values: dict[str, float]) -> list[float]:
    top = max(values.values())
    return [values[name] / top for name in SHAPES]


def test_binary_blendshapes_threshold_is_relative_and_empty_rows_are_false(square):
    masks = packing.binary_blendshapes(square.deltas, mu=0.3)
    assert masks.tolist() == [
        [True, False, False, False],
        [False, False, True, True],
        [True, False, False, False],
        [True, False, False, False],
        [False, False, False, False],
    ]
    assert packing.binary_blendshapes(square.deltas, mu=0.15)[0].tolist() == [True, True, False, False]
    assert packing.empty_shapes(square) == ("E",)


def test_binary_blendshapes_noise_below_floor_is_empty():
    deltas = np.zeros((2, 3, 3))
    deltas[0, 0] = (1.0, 0, 0)
    deltas[1, 1] = (1e-9, 0, 0)  # float noise: far below 1e-6 of the largest displacement
    masks = packing.binary_blendshapes(deltas)
    assert masks[1].sum() == 0
    assert packing.binary_blendshapes(deltas, noise_floor=0.0)[1].tolist() == [False, True, False]


@pytest.mark.parametrize("mu", [0.0, -0.1, 1.5, float("nan")])
def test_binary_blendshapes_rejects_mu_outside_unit_interval(mu):
    with pytest.raises(ValueError, match=rf"mu must be in \(0, 1\], got {mu}"):
        packing.binary_blendshapes(np.zeros((1, 2, 3)), mu=mu)


def test_displacement_strength_eq5(square):
    weights = packing.importance(square, STRETCHED, alpha=1.0)
    assert weights == pytest.approx(_expected(MEAN))


def test_triangle_distortion_eq6_uses_the_second_vertex():
    assert triangle_distortion(SQUARE, STRETCHED, TRIANGLES) == pytest.approx([S_T0, S_T1])
    # Rotating the triangle's vertex order moves v, and the value with it.
    rotated = TRIANGLES[:, [1, 2, 0]]
    assert triangle_distortion(SQUARE, STRETCHED, rotated)[0] != pytest.approx(S_T0)
    assert triangle_distortion(SQUARE, SQUARE, TRIANGLES) == pytest.approx([2.0, 2.0])


def test_triangle_distortion_eq7(square):
    weights = packing.importance(square, STRETCHED, alpha=0.0)
    assert weights == pytest.approx(_expected(SUM_S))


def test_uniqueness_eq8_clips_negative_cosines_and_inverts(square):
    base = 0.5 * np.array(_expected(MEAN)) + 0.5 * np.array(_expected(SUM_S))
    weights = packing.importance(square, STRETCHED, alpha=0.5, beta=0.5, used=["A"])
    # U_B = 0 (orthogonal), U_C = cos(C, A), U_D = max(-cos, 0) = 0; lambda_U = 1 - U / max U over B, C, D.
    unique = {"A": 0.0, "B": 1.0, "C": 1.0 - COS_CA / COS_CA, "D": 1.0, "E": 0.0}
    assert weights == pytest.approx(base + 0.5 * np.array([unique[name] for name in SHAPES]))


def test_uniqueness_is_zero_before_the_first_expression(square):
    first = packing.importance(square, STRETCHED, beta=0.7)
    assert first == pytest.approx(packing.importance(square, STRETCHED, beta=0.0))


def test_uniqueness_when_nothing_resembles_the_used_shapes(square):
    weights = packing.importance(square, STRETCHED, alpha=1.0, beta=1.0, used=["B"])
    assert weights == pytest.approx(np.array(_expected(MEAN)) + [1.0, 0.0, 1.0, 1.0, 0.0])


def test_without_target_distortion_is_zero_and_a_warning_says_so(square):
    with pytest.warns(packing.MissingTargetWarning, match="triangle distortion"):
        weights = packing.importance(square)
    assert weights == pytest.approx(0.5 * np.array(_expected(MEAN)))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        packing.importance(square, alpha=1.0)  # alpha = 1 does not use the term: no warning


def test_no_importance_mode_weighs_every_shape_one(square):
    problem = packing.build_problem(square, importance=False, symmetry=False)
    assert problem.unperturbed_objective(range(problem.n_items)) == pytest.approx(4.0)
    assert np.all(np.abs(problem.weights - 1.0) < 1e-5)


def test_target_rig_is_accepted_like_its_neutral(square):
    target = Rig(STRETCHED, square.deltas, TRIANGLES, square.names)
    assert packing.importance(square, target) == pytest.approx(packing.importance(square, STRETCHED))


def test_target_with_other_topology_is_refused(square):
    with pytest.raises(ValueError, match=r"target_neutral has shape \(3, 3\).*4 vertices"):
        packing.importance(square, STRETCHED[:3])
    other = Rig(
        STRETCHED,
        square.deltas,
        TRIANGLES[:, ::-1],
        square.names,
        provenance=rigs.Provenance(source="other.npz"),
    )
    with pytest.raises(ValueError, match="target rig 'other.npz' has other topology"):
        packing.importance(square, other)


def test_collapsed_edge_is_left_out_of_the_distortion_and_reported(square):
    collapsed = STRETCHED.copy()
    collapsed[3] = collapsed[2]
    with pytest.warns(DegenerateDistortionWarning, match=r"1 triangle.*first: triangle 1 \[1, 3, 2\]"):
        distortion = triangle_distortion(square.neutral, collapsed, square.triangles)
    assert distortion[1] == 0.0
    assert distortion[0] == pytest.approx(triangle_distortion(square.neutral, STRETCHED, square.triangles)[0])


def test_one_sliver_does_not_swamp_the_other_triangles(square):
    sliver = square.neutral.copy()
    sliver[3] = sliver[2] + 1e-9 * (sliver[3] - sliver[2])
    with pytest.warns(DegenerateDistortionWarning):
        distortion = triangle_distortion(sliver, STRETCHED, square.triangles)
    assert distortion[1] == 0.0 and distortion[0] >= 2.0


@pytest.mark.parametrize(
    ("argument", "value", "message"),
    [
        ("alpha", 1.5, r"alpha must be in \[0, 1\], got 1.5"),
        ("alpha", -0.1, r"alpha must be in \[0, 1\], got -0.1"),
        ("beta", -1.0, r"beta must be in \[0, inf\), got -1.0"),
        ("mu", 0.0, r"mu must be in \(0, 1\], got 0.0"),
    ],
)
def test_parameters_out_of_range_are_named(square, argument, value, message):
    with pytest.raises(ValueError, match=message):
        packing.importance(square, STRETCHED, **{argument: value})


def test_unknown_used_shape_is_named(square):
    with pytest.raises(RigError, match="no blendshape named 'Z'"):
        packing.importance(square, STRETCHED, used=["Z"])


def test_rig_whose_every_shape_is_empty_is_refused():
    rig = Rig(
        SQUARE, np.zeros((2, 4, 3)), TRIANGLES, ("x", "y"), provenance=rigs.Provenance(source="flat.npz")
    )
    with pytest.raises(ValueError, match="rig 'flat.npz': every one of its 2 blendshapes is empty"):
        packing.importance(rig, STRETCHED)
    with pytest.raises(ValueError, match="every one of its 2 blendshapes is empty"):
        packing.analyse(rig, STRETCHED)


@pytest.mark.parametrize("shape_symmetry", [True, False])
def test_rig_without_blendshapes_is_refused_by_name(shape_symmetry):
    rig = Rig(SQUARE, np.zeros((0, 4, 3)), TRIANGLES, (), provenance=rigs.Provenance(source="bare.npz"))
    with pytest.raises(HarnessError, match="rig 'bare.npz' has no blendshapes"):
        packing.analyse(rig, STRETCHED, shape_symmetry=shape_symmetry)
    with pytest.raises(HarnessError, match="rig 'bare.npz' has no blendshapes"):
        packing.importance(rig, STRETCHED)


# The excess variant of eq. 6 (the authors' code: s_t - 2) ---------------------------------------------


def test_excess_distortion_is_the_paper_value_minus_two():
    paper = triangle_distortion(SQUARE, STRETCHED, TRIANGLES)
    assert triangle_distortion(SQUARE, STRETCHED, TRIANGLES, "excess") == pytest.approx(paper - 2.0)
    assert np.all(triangle_distortion(SQUARE, SQUARE, TRIANGLES, "excess") == 0.0)
    # A similar triangle scaled by c has s_t = 2 max(c, 1/c): excess 2 (c - 1) even though no angle changed.
    assert triangle_distortion(SQUARE, 1.5 * SQUARE, TRIANGLES, "excess") == pytest.approx([1.0, 1.0])


def test_excess_distortion_of_a_target_equal_to_the_template_adds_nothing(square):
    # The paper's eq. 6 gives 2 per touched triangle: A, C, D touch one triangle, B two.
    assert packing.importance(square, SQUARE, alpha=0.0) == pytest.approx([0.5, 1.0, 0.5, 0.5, 0.0])
    assert np.all(packing.importance(square, SQUARE, alpha=0.0, distortion="excess") == 0.0)
    assert packing.importance(square, SQUARE, distortion="excess") == pytest.approx(
        0.5 * np.array(_expected(MEAN))
    )


def test_excess_and_paper_rank_the_shapes_of_a_warped_rig_differently():
    from scipy.stats import spearmanr

    template = rigs.generate("toon")
    target = rigs.warp(template, "alien+character")
    paper = packing.importance(template, target, alpha=0.0)
    excess = packing.importance(template, target, alpha=0.0, distortion="excess")
    touched = paper > 0
    assert not np.array_equal(np.argsort(-paper), np.argsort(-excess))
    assert spearmanr(paper[touched], excess[touched]).statistic < 0.99
    analysed = packing.analyse(template, target, distortion="excess", symmetry=False)
    assert analysed.params.distortion == "excess"
    assert analysed.terms.distortion == pytest.approx(excess)


def test_unknown_distortion_is_refused(square):
    with pytest.raises(ValueError, match="distortion must be"):
        packing.importance(square, STRETCHED, distortion="ratio")
    with pytest.raises(ValueError, match="distortion must be"):
        triangle_distortion(SQUARE, STRETCHED, TRIANGLES, "ratio")


@pytest.mark.parametrize("entries", [1, 37, 1000])
def test_eq7_summed_a_block_of_shapes_at_a_time_equals_all_at_once(monkeypatch, entries):
    """`distortion_strength` bounds its transient by gathering ``DISTORTION_ENTRIES`` active entries at a
    time; every block size gives the sums of one block of all the shapes, bit for bit."""
    import packing._importance as importance

    rig = rigs.generate("male", seed=3)
    masks = packing.binary_blendshapes(rig.deltas, 0.3)
    distortion = triangle_distortion(rig.neutral, rigs.warp(rig, "alien").neutral, rig.triangles)
    monkeypatch.setattr(importance, "DISTORTION_ENTRIES", 1 << 40)
    whole = importance.distortion_strength(distortion, masks, rig.triangles)
    monkeypatch.setattr(importance, "DISTORTION_ENTRIES", entries)
    blocked = importance.distortion_strength(distortion, masks, rig.triangles)
    assert whole.shape == (rig.n_shapes,) and whole.max() == 1.0
    np.testing.assert_array_equal(blocked, whole)
