"""The independent checker catches every kind of violation, from the raw deltas."""

from __future__ import annotations

import dataclasses
import re
import warnings

import pytest

import packing
from packing import CheckError


@pytest.fixture(autouse=True)
def _quiet():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", packing.MissingTargetWarning)
        yield


def _violation(rig, expressions, **params) -> CheckError:
    with pytest.raises(CheckError) as caught:
        packing.check(rig, expressions, **params)
    return caught.value


def test_a_valid_sequence_passes_in_every_form(face, exact_solver):
    rig, _ = face
    expressions = packing.sequence(rig, exact_solver)
    packing.check(rig, expressions)
    packing.check(rig, [list(e.shapes) for e in expressions])
    packing.check(rig, [{"shapes": list(e.shapes), "extra_examples": []} for e in expressions])


@pytest.mark.parametrize(
    ("expressions", "kind", "number", "message"),
    [
        ([["browUp_R", "browUp_L", "smile"]], "unknown", 1, "no blendshape named 'smile'"),
        ([["noseWrinkle", "noseWrinkle"]], "duplicate", 1, "'noseWrinkle' appears twice"),
        ([["noseWrinkle", "empty"]], "empty", 1, "'empty' is an empty blendshape"),
        (
            [["noseWrinkle"], ["jawForward", "noseWrinkle"]],
            "repeat",
            2,
            "'noseWrinkle' was already the primary",
        ),
        ([["browUp_R"]], "pair", 1, "'browUp_R' is primary without its symmetry partner 'browUp_L'"),
        ([["upperLipUp", "noseWrinkle"]], "pair", 1, "without its symmetry partner 'lowerLipDown'"),
        (
            [["browUp_R", "browUp_L", "browDown_R"]],
            "overlap",
            1,
            "'browUp_R' and 'browDown_R' share \\d+ active",
        ),
        (
            [{"shapes": ["noseWrinkle"], "extra_examples": ["jawForward"]}],
            "extra",
            1,
            "extra example 'jawForward' was not the primary example of an earlier expression",
        ),
        (
            [["cheekPuff_R", "cheekPuff_L"], {"shapes": ["noseWrinkle"], "extra_examples": ["cheekPuff_R"]}],
            "pair",
            2,
            "'cheekPuff_R' is extra without its symmetry partner",
        ),
        (
            [["browDown_R"], {"shapes": ["jawForward"], "extra_examples": ["browDown_R", "jawForward"]}],
            "duplicate",
            2,
            "'jawForward' appears twice",
        ),
        (
            [
                ["browUp_R", "browUp_L"],
                {"shapes": ["browDown_R"], "extra_examples": ["browUp_R", "browUp_L"]},
            ],
            "overlap",
            2,
            "share",
        ),
    ],
)
def test_each_violation_is_caught_and_named(face, expressions, kind, number, message):
    rig, _ = face
    error = _violation(rig, expressions)
    assert (error.kind, error.expression) == (kind, number)
    assert str(error).startswith(f"expression {number}: ")
    assert error.args[0] == str(error)
    assert re.search(message, str(error))


def test_cap_counts_primary_and_extra_shapes(face):
    rig, _ = face
    expressions = [
        ["browDown_R"],
        {"shapes": ["jawForward", "noseWrinkle"], "extra_examples": ["browDown_R"]},
    ]
    packing.check(rig, expressions, max_per_expression=3)
    error = _violation(rig, expressions, max_per_expression=2)
    assert (error.kind, error.expression) == ("cap", 2)
    assert "3 blendshapes exceed max_per_expression=2" in str(error)


def test_masks_are_recomputed_with_the_given_mu(face, exact_solver):
    rig, _ = face
    expressions = packing.sequence(rig, exact_solver, mu=0.5)
    packing.check(rig, expressions, mu=0.5)
    assert _violation(rig, expressions, mu=0.05).kind == "overlap"


def test_a_pair_may_overlap_itself_but_nothing_else(kit):
    # The halves share a strip at the symmetry axis (7 of 24 active vertices): the overlap sec. 4.4.1 allows.
    right = kit.Bump("pucker_R", (0.08, 0.0), (0.12, 0.12), (0.3, 0.0, 1.0))
    rig = kit.face_rig([right, kit.mirrored(right, "pucker_L")], regions={})
    masks = packing.binary_blendshapes(rig.deltas)
    assert (masks[0] & masks[1]).any()  # the pair overlaps at the symmetry axis
    assert packing.find_symmetry_pairs(rig) == [("pucker_R", "pucker_L")]
    packing.check(rig, [["pucker_R", "pucker_L"]])
    assert _violation(rig, [["pucker_R", "pucker_L"]], symmetry=False).kind == "overlap"
    packing.check(rig, [["pucker_R"], ["pucker_L"]], pairs=[])
    assert _violation(rig, [["pucker_R"], ["pucker_L"]]).kind == "pair"


def test_allowed_overlap_needs_an_order_of_addition(kit):
    # Big a and small b overlap: the shared vertices are a small share of a and a large share of b,
    # so adding b first and then a can respect an allowed fraction that adding a first cannot.
    a = kit.Bump("a", (-0.2, 0.0), (0.3, 0.3), (0, 0, 1.0))
    b = kit.Bump("b", (0.12, 0.0), (0.12, 0.12), (0, 0, 1.0))
    far = kit.Bump("c", (0.0, 0.8), (0.1, 0.1), (0, 0, 1.0))
    rig = kit.face_rig([a, b, far], regions={})
    masks = packing.binary_blendshapes(rig.deltas)
    shared = (masks[0] & masks[1]).sum()
    share_of_a, share_of_b = shared / masks[0].sum(), shared / masks[1].sum()
    assert 0 < share_of_a < share_of_b < 1
    packing.check(rig, [["a", "b", "c"]], symmetry=False, overlap=(share_of_a + share_of_b) / 2)
    error = _violation(rig, [["a", "b", "c"]], symmetry=False, overlap=share_of_a / 2)
    assert error.kind == "overlap" and "no order of adding 'a', 'b' keeps" in str(error)
    with pytest.raises(ValueError, match=r"overlap must be a fraction in \[0, 1\), got 1.0"):
        packing.check(rig, [["a"]], overlap=1.0)


def test_unreadable_expression_is_a_type_error(face):
    rig, _ = face
    with pytest.raises(TypeError, match="cannot read the shapes of 3"):
        packing.check(rig, [3])


def _solved(expression, **changes):
    """An expression of a real sequence with some fields, of it or of its solution, changed (a lying or
    lazy solver's answer)."""
    own_fields = {field.name for field in dataclasses.fields(packing.Expression)}
    own = {name: value for name, value in changes.items() if name in own_fields}
    solution = {name: value for name, value in changes.items() if name not in own_fields}
    return dataclasses.replace(
        expression, solution=dataclasses.replace(expression.solution, **solution), **own
    )


def test_a_bound_below_the_objective_is_rejected(face, exact_solver):
    rig, _ = face
    expressions = packing.sequence(rig, exact_solver, target_neutral=rig.neutral)
    packing.check(rig, expressions)
    lying = [_solved(expressions[0], bound=expressions[0].objective - 0.01), *expressions[1:]]
    with pytest.raises(packing.CheckError) as found:
        packing.check(rig, lying)
    assert found.value.kind == "bound" and found.value.expression == 1


def test_maximal_rejects_an_expression_with_room_left(face, exact_solver):
    rig, _ = face
    expressions = packing.sequence(rig, exact_solver, target_neutral=rig.neutral)
    packing.check(rig, expressions, maximal=True)
    first = expressions[0]
    paired = {name for pair in packing.analyse(rig, rig.neutral).pairs for name in pair}
    dropped = [name for name in first.shapes if name not in paired]
    assert dropped, "the first expression must hold an unpaired shape for this test"
    lazy = _solved(first, shapes=tuple(name for name in first.shapes if name != dropped[0]))
    with pytest.raises(packing.CheckError) as found:
        packing.check(rig, [lazy], maximal=True)
    assert found.value.kind == "maximal" and dropped[0] in str(found.value)
    packing.check(rig, [lazy])  # without maximal= only validity is checked
    packing.check(rig, [lazy], maximal=True, rejected={1: [dropped[0]]})  # the artist rejected it
    time_limited = _solved(lazy, termination=packing.Termination.TIME_LIMIT)
    packing.check(rig, [time_limited], maximal=True)  # an incumbent need not be maximal
    nothing = _solved(first, shapes=(), termination=packing.Termination.COMPLETED)
    with pytest.raises(packing.CheckError, match="still fits beside nothing"):
        packing.check(rig, [nothing], maximal=True)
