"""Bad input gives one clear error naming the argument and the shape."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import transfer
from rigs import RigError

METHODS = ["delta", "dt", "ebfr", "ebfr-full", "plbs"]


@pytest.fixture
def setting(sheet):
    template = sheet(8, 9, 4)
    target = replace(template, neutral=template.neutral * 1.1)
    weights = np.array([[1.0, 0.0, 1.0, 0.0], [0.0, 1.0, 0.0, 1.0]])
    return template, target, weights, transfer.training_expressions(target, weights)


@pytest.mark.parametrize("name", METHODS)
def test_template_must_be_a_rig(name, setting):
    template, target, weights, examples = setting
    with pytest.raises(ValueError, match=r"template must be a rigs.Rig, got ndarray"):
        transfer.get(name)(template.neutral, target.neutral, weights, examples)


@pytest.mark.parametrize("name", METHODS)
def test_target_with_other_vertex_count(name, setting):
    template, target, weights, examples = setting
    with pytest.raises(ValueError, match=r"target_neutral must have shape \(72, 3\) .*got \(71, 3\)"):
        transfer.get(name)(template, target.neutral[:-1], weights, examples)


@pytest.mark.parametrize("name", METHODS)
def test_target_rig_with_other_triangles(name, setting):
    template, target, weights, examples = setting
    other = replace(target, triangles=target.triangles[:, [0, 2, 1]])
    with pytest.raises(RigError, match=r"target_neutral: .* does not share the template's topology"):
        transfer.get(name)(template, other, weights, examples)


@pytest.mark.parametrize("name", METHODS)
def test_target_rig_with_same_topology_is_accepted(name, setting):
    template, target, weights, examples = setting
    result = transfer.get(name)(template, target, weights, examples)
    assert result.shape == template.deltas.shape


@pytest.mark.parametrize("name", METHODS)
def test_weights_with_other_shape_count(name, setting):
    template, target, weights, examples = setting
    with pytest.raises(ValueError, match=r"weights must have shape \(J, 4\) .*got \(2, 3\)"):
        transfer.get(name)(template, target.neutral, weights[:, :3], examples)


@pytest.mark.parametrize("name", METHODS)
def test_examples_count_must_match_weight_rows(name, setting):
    template, target, weights, examples = setting
    with pytest.raises(
        ValueError, match=r"examples holds 1 expressions but weights has 2 rows \(shape \(2, 4\)\)"
    ):
        transfer.get(name)(template, target.neutral, weights, examples[:1])


@pytest.mark.parametrize("name", METHODS)
def test_examples_on_other_topology(name, setting):
    template, target, weights, examples = setting
    with pytest.raises(ValueError, match=r"examples must have shape \(J, 72, 3\) .*got \(2, 70, 3\)"):
        transfer.get(name)(template, target.neutral, weights, examples[:, :70])


@pytest.mark.parametrize("name", METHODS)
def test_weights_without_examples(name, setting):
    template, target, weights, _ = setting
    with pytest.raises(ValueError, match=r"examples is missing but weights has 2 rows"):
        transfer.get(name)(template, target.neutral, weights)


@pytest.mark.parametrize("name", METHODS)
@pytest.mark.parametrize(
    ("argument", "position", "message"),
    [
        ("target_neutral", (5, 1), r"target_neutral has a non-finite value at index \[5, 1\]"),
        ("weights", (1, 2), r"weights has a non-finite value at index \[1, 2\]"),
        ("examples", (0, 3, 2), r"examples has a non-finite value at index \[0, 3, 2\]"),
    ],
)
def test_non_finite_values(name, argument, position, message, setting):
    template, target, weights, examples = setting
    arguments = {
        "target_neutral": target.neutral.copy(),
        "weights": weights.copy(),
        "examples": examples.copy(),
    }
    arguments[argument][position] = np.nan
    with pytest.raises(ValueError, match=message):
        transfer.get(name)(template, arguments["target_neutral"], arguments["weights"], arguments["examples"])


def test_ebfr_requires_binary_weights(setting):
    template, target, weights, examples = setting
    weights = weights.copy()
    weights[0, 1] = 0.5
    with pytest.raises(ValueError, match=r"weights must be 0 or 1 for 'ebfr' .*weights\[0, 1\] = 0.5"):
        transfer.get("ebfr")(template, target.neutral, weights, examples)


@pytest.mark.parametrize("name", ["plbs", "ebfr-full", "dt", "delta"])
def test_fractional_weights_are_accepted_elsewhere(name, setting):
    template, target, weights, examples = setting
    weights = weights * 0.5
    result = transfer.get(name, **({"iterations": 2} if name == "ebfr-full" else {}))(
        template, target.neutral, weights, examples
    )
    assert np.isfinite(result).all()


def test_ebfr_full_requires_weights_in_unit_interval(setting):
    template, target, weights, examples = setting
    weights = weights.copy()
    weights[1, 3] = 1.5
    with pytest.raises(
        ValueError, match=r"weights must lie in \[0, 1\] for 'ebfr-full' .*weights\[1, 3\] = 1.5"
    ):
        transfer.get("ebfr-full")(template, target.neutral, weights, examples)


def test_training_expressions_checks_weights(setting):
    _, target, weights, _ = setting
    with pytest.raises(ValueError, match=r"weights must have shape \(J, 4\) .*got \(4,\)"):
        transfer.training_expressions(target, weights[0])
    with pytest.raises(ValueError, match=r"target must be a rigs.Rig, got ndarray"):
        transfer.training_expressions(target.neutral, weights)
