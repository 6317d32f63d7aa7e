"""The public names that outside checks call exist with the documented signatures."""

import dataclasses
import inspect
import json
import warnings

import numpy as np
import pytest
from click.testing import CliRunner

import packing
import rigs
import solvers
import transfer
from harness.cli import cli


def _parameters(function):
    return inspect.signature(function).parameters


def test_rigs_surface():
    for name in ("Rig", "RigError", "load", "save", "generate", "warp", "PRESETS", "WARPS"):
        assert hasattr(rigs, name), name
    assert _parameters(rigs.generate)["seed"].default == 0
    rig = rigs.generate("tiny")
    assert {field.name for field in dataclasses.fields(rig.truth)} >= {
        "mirror_pairs",
        "motion_pairs",
        "self_symmetric",
    }
    assert rigs.warp(rig, "big-eyes").deltas.shape == rig.deltas.shape
    assert issubclass(rigs.RigError, Exception)


def test_packing_surface():
    assert _parameters(packing.binary_blendshapes)["mu"].default == 0.3
    params = _parameters(packing.importance)
    assert params["target_neutral"].default is None
    assert (params["alpha"].default, params["beta"].default) == (0.5, 0.0)
    assert params["used"].kind is inspect.Parameter.KEYWORD_ONLY
    params = _parameters(packing.find_symmetry_pairs)
    assert (params["mu"].default, params["shape"].default, params["motion"].default) == (0.3, True, True)
    params = _parameters(packing.sequence)
    assert params["target_neutral"].default is None and params["jmax"].default is None
    assert issubclass(packing.CheckError, Exception)

    rig = rigs.generate("tiny")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", packing.MissingTargetWarning)
        masks = packing.binary_blendshapes(rig.deltas)
        weights = packing.importance(rig)
        pairs = packing.find_symmetry_pairs(rig)
        problem = packing.build_problem(rig)
        expressions = packing.sequence(rig, solvers.get("cpsat"), jmax=3)
    assert masks.shape == (rig.n_shapes, rig.n_vertices) and masks.dtype == bool
    assert weights.shape == (rig.n_shapes,)
    assert all(isinstance(a, str) and isinstance(b, str) for a, b in pairs)
    assert isinstance(problem, packing.PackingProblem)
    assert 1 <= len(expressions) <= 3
    for expression in expressions:
        assert set(expression.shapes) <= set(rig.names)
        assert expression.objective > 0 and expression.status
    packing.check(rig, expressions)


def test_solvers_surface():
    names = solvers.names()
    built_in = {"cbc-pulp", "cbc-mip", "highs", "cpsat", "naive-pulp-cbc", "greedy", "greedy-overlap"}
    assert built_in <= set(names)
    assert set(solvers.names(available_only=True)) <= set(names)
    params = _parameters(solvers.get("highs").solve)
    assert params["time_limit"].default is None and params["seed"].default == 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", packing.MissingTargetWarning)
        problem = packing.build_problem(rigs.generate("tiny"))
    solution = solvers.get("highs").solve(problem)
    assert solution.termination == "optimal"
    assert solution.objective == pytest.approx(problem.unperturbed_objective(solution.items), rel=1e-12)
    assert all(isinstance(shape, str) for shape in solution.shapes)


def test_transfer_surface():
    assert {"delta", "dt", "ebfr", "plbs"} <= set(transfer.names())
    rig = rigs.generate("tiny")
    target = rigs.warp(rig, "big-eyes")
    weights = np.zeros((1, rig.n_shapes))
    weights[0, 0] = 1
    examples = transfer.training_expressions(target, weights)
    assert examples.shape == (1, rig.n_vertices, 3)
    estimate = transfer.get("ebfr")(rig, target.neutral, weights, examples)
    assert estimate.shape == rig.deltas.shape
    assert transfer.rms(target.deltas, target.deltas) == 0.0
    assert transfer.rms(estimate, target.deltas) > 0.0


def test_harness_list_json():
    result = CliRunner().invoke(cli, ["list", "--json"])
    assert result.exit_code == 0, result.output
    listing = json.loads(result.output)
    assert {row["name"] for row in listing["solvers"]} >= {"cpsat", "highs", "greedy"}
