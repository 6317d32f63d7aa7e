"""Example-based rigging's memoised set-up and per-expression fit give the joint fit of Li et al., exactly."""

from __future__ import annotations

import numpy as np
import pytest

import rigs
import transfer
from transfer import ebfr
from transfer._frames import edge_vectors, shape_major, vertex_major


@pytest.fixture(scope="module")
def case():
    template = rigs.generate("tiny", seed=1)
    target = rigs.warp(template, "alien+character")
    weights = np.zeros((3, template.n_shapes))
    for j, shapes in enumerate(([0, 3, 6], [1, 4], [7, 9, 10])):
        weights[j, shapes] = 1.0
    return template, target, weights, transfer.scan_expressions(target, weights, seed=1)


def joint(template, target, weights, examples, beta=0.1):
    """Step A solved for all shapes at once, from a fresh set-up (no memo, no per-expression split)."""
    setup = ebfr.RiggingSetup(
        template,
        target.neutral,
        kappa=0.1,
        theta=2.0,
        motion_scale="peak",
        static_tolerance=1e-6,
        align=True,
        factor_budget=0,
    )
    observed = edge_vectors(vertex_major(examples - target.neutral), template.triangles)
    edges = ebfr.fit_edge_frames(setup.prior, setup.regularisation, weights, observed, beta)
    return shape_major(setup.reconstruction.solve(edges, setup.fixed, setup.template_deltas))


def test_a_packing_fits_each_expression_alone_and_matches_the_joint_fit(case):
    template, target, weights, examples = case
    method = transfer.get("ebfr")
    for j in (1, 2, 3):
        found = method(template, target.neutral, weights[:j], examples[:j])
        np.testing.assert_allclose(found, joint(template, target, weights[:j], examples[:j]), atol=1e-12)


def test_shared_shapes_take_the_joint_path(case):
    template, target, weights, examples = case
    shared = weights.copy()
    shared[2, 0] = 1.0  # shape 0 in two expressions: the expressions are coupled
    found = transfer.get("ebfr")(template, target.neutral, shared, examples)
    np.testing.assert_allclose(found, joint(template, target, shared, examples), atol=1e-12)


def test_the_diagonal_solve_equals_the_woodbury_solve():
    rng = np.random.default_rng(3)
    prior = rng.normal(size=(40, 2, 3, 12))
    regularisation = rng.uniform(1.0, 100.0, (40, 12))
    observed = rng.normal(size=(40, 2, 3, 4))
    weights = np.zeros((4, 12))
    weights[rng.integers(0, 4, 12), np.arange(12)] = rng.uniform(0.2, 1.0, 12)
    coupled = weights.copy()
    coupled[(np.flatnonzero(weights[:, 0])[0] + 1) % 4, 0] = 1e-300  # forces the general path
    np.testing.assert_allclose(
        ebfr.fit_edge_frames(prior, regularisation, weights, observed, 0.1),
        ebfr.fit_edge_frames(prior, regularisation, coupled, observed, 0.1),
        atol=1e-12,
    )


PARAMS = {"kappa": 0.1, "theta": 2.0, "motion_scale": "peak", "static_tolerance": 1e-6, "align": True}


def test_the_setup_is_shared_by_equal_rigs_and_remembers_expressions(case):
    template, target, weights, examples = case
    first = ebfr.rigging_setup(template, target.neutral, **PARAMS)
    fresh = rigs.generate("tiny", seed=1)  # another object with the same content
    assert ebfr.rigging_setup(fresh, rigs.warp(fresh, "alien+character").neutral, **PARAMS) is first
    assert ebfr.rigging_setup(template, target.neutral, **{**PARAMS, "kappa": 0.2}) is not first
    transfer.get("ebfr")(template, target.neutral, weights, examples)
    remembered = len(first.expressions)
    transfer.get("ebfr")(template, target.neutral, weights[:2], examples[:2])
    assert len(first.expressions) == remembered  # the first two expressions were fitted already
    without = joint(template, target, weights[:0], examples[:0])  # no expression: deformation transfer
    np.testing.assert_array_equal(shape_major(first.transferred), without)
