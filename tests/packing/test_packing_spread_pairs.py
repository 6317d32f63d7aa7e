"""Sec. 4.4.1's overlap check: mirror images spread over both facial halves are never paired, on real and
generated rigs, and no expression ends up holding two shapes that cancel."""

from __future__ import annotations

import dataclasses
import warnings

import pytest

import packing
import rigs
import solvers

PRESETS = ["arkit52", "male", "toon", "digidouble", "female"]
SPREAD = {"jawLeft", "jawRight", "mouthLeft", "mouthRight"}


def _analyse(rig, **params):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", packing.MissingTargetWarning)
        return packing.analyse(rig, **params)


def test_faceunits_never_pairs_shapes_spread_over_both_halves(faceunits):
    analysis = _analyse(faceunits)
    paired = {name for pair in analysis.pairs for name in pair}
    assert not paired & SPREAD
    refused = {frozenset(faceunits.names[k] for k in pair) for pair in analysis.symmetry.overlapping}
    assert {frozenset(("jawLeft", "jawRight")), frozenset(("mouthLeft", "mouthRight"))} <= refused
    assert any("spread over both" in note and "jawLeft+jawRight" in note for note in analysis.notes)
    # The one-sided pairs stay: blinks, smiles, brows, sneers ...
    assert len(analysis.symmetry.shape_pairs) >= 16
    for left, right in analysis.pairs:
        assert left.removesuffix("Left") == right.removesuffix("Right"), (left, right)


@pytest.mark.parametrize("preset", PRESETS)
def test_generated_spread_images_are_refused_and_true_pairs_kept(preset):
    rig = rigs.generate(preset)
    truth = rig.truth
    analysis = _analyse(rig, motion_symmetry=False)
    assert {frozenset(p) for p in analysis.pairs} == {frozenset(p) for p in truth.mirror_pairs}
    refused = {frozenset(rig.names[k] for k in pair) for pair in analysis.symmetry.overlapping}
    assert refused == {frozenset(p) for p in truth.spread_mirror_images}


def test_a_larger_allowance_pairs_them_again():
    rig = rigs.generate("male")
    assert frozenset(("jawLeft", "jawRight")) in {frozenset(p) for p in _analyse(rig, pair_overlap=1.0).pairs}


@pytest.mark.parametrize("solver", ["cpsat", "greedy"])
@pytest.mark.parametrize("preset", PRESETS)
def test_no_expression_of_a_generated_rig_keeps_a_spread_image_pair_together(preset, solver):
    rig = rigs.generate(preset)
    analysis = _analyse(rig)
    expressions = packing.sequence(rig, solvers.get(solver), analysis=analysis)
    spread = [set(pair) for pair in rig.truth.spread_mirror_images]
    for expression in expressions:
        held = set(expression.shapes) | set(expression.extra_examples)
        assert not any(pair <= held for pair in spread), (expression.index, held)
    packing.check(rig, expressions, maximal=True)


@pytest.mark.parametrize("preset", PRESETS)
def test_cancelling_twins_are_exactly_the_spread_images(preset):
    rig = rigs.generate(preset)
    found = {frozenset(c.shapes) for c in packing.cancelling_twins(rig)}
    assert found == {frozenset(pair) for pair in rig.truth.spread_mirror_images}
    for cancellation in packing.cancelling_twins(rig):
        assert cancellation.ratio < packing.CANCEL_RATIO
        assert "cancel" in cancellation.message and cancellation.expression is None


def test_a_forced_cancelling_pair_is_reported_in_its_expression():
    rig = rigs.generate("male")
    analysis = _analyse(rig, together=[("jawLeft", "jawRight")])
    expressions = packing.sequence(rig, solvers.get("cpsat"), analysis=analysis)
    found = packing.find_cancellations(rig, [e.shapes + e.extra_examples for e in expressions])
    holding = next(e.index for e in expressions if "jawLeft" in e.shapes)
    assert [(c.shapes, c.expression) for c in found] == [(("jawLeft", "jawRight"), holding)]
    assert found[0].message.startswith(f"expression {holding} holds jawLeft and jawRight")


@pytest.mark.parametrize("extra_examples", [False, True])
def test_no_faceunits_expression_holds_a_cancelling_pair(faceunits, extra_examples):
    for solver in ("cpsat", "greedy", "greedy-overlap"):
        expressions = packing.sequence(
            faceunits, solvers.get(solver), analysis=_analyse(faceunits, extra_examples=extra_examples)
        )
        groups = [e.shapes + e.extra_examples for e in expressions]
        assert packing.find_cancellations(faceunits, groups) == [], solver
        if solver == "greedy-overlap":  # its shapes overlap, so the detector has pairs to judge
            assert packing.find_cancellations(faceunits, groups, ratio=1.0)


def test_pairs_are_cross_checked_against_left_right_names():
    rig = rigs.generate("male")
    (a_left, a_right), (b_left, b_right) = rig.truth.mirror_pairs[:2]
    names = list(rig.names)
    ia, ib = names.index(a_right), names.index(b_right)
    names[ia], names[ib] = b_right, a_right  # the right halves of two pairs swap names
    swapped = dataclasses.replace(rig, names=tuple(names))
    notes = _analyse(swapped).notes
    contradicting = next(note for note in notes if "names are not twins" in note)
    assert f"{a_left}+{b_right}" in contradicting or f"{b_right}+{a_left}" in contradicting
    missed = next(note for note in notes if "twins that geometry did not pair" in note)
    assert f"{a_left}/{a_right}" in missed and f"{b_left}/{b_right}" in missed
    assert not any("names are not twins" in note or "did not pair" in note for note in _analyse(rig).notes)
