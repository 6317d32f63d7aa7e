"""Conformance checks for transfer plugins, as `solvers.testing` has for solvers.

Each check runs the method on a small generated rig (a smooth sheet with local bump blendshapes) and fails
with an `AssertionError` naming what is wrong. They hold for any method that estimates a target's
blendshapes from its neutral and training expressions (Carrigan et al. 2020, sec. 3, eq. 1):

- **declaration**: a `transfer.Transfer` with a name and boolean ``binary_weights`` / ``uses_examples``;
- **output**: ``(K, N, 3)`` finite floats in a new array, the template untouched;
- **identity**: the template transferred to itself, with its own expressions as examples, is itself;
- **translation**: a target that is the template moved rigidly by a translation gets the template's
  deltas (a delta is a difference of positions);
- **prefixes**: ``prefixes(...)(j)`` equals the method called with the first j expressions (sec. 5.2);
- **determinism**: two calls agree bit for bit;
- **examples**: a method declaring ``uses_examples = False`` returns the same with and without them;
- **refusal**: a target neutral of another vertex count is a `ValueError` naming the target.

Examples
--------
::

    from transfer.testing import parametrize_with_checks

    @parametrize_with_checks([MyTransfer()])
    def test_my_transfer(method, check):
        check(method)
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np

from registry import parametrize_checks, run_checks
from transfer._base import Transfer

#: Relative tolerance (to the largest template displacement) of the exactness checks: the methods solve
#: least-squares systems in double precision, whose residuals on these small rigs are far below it.
EXACT_TOLERANCE = 1e-6


@dataclass(frozen=True)
class _Case:
    """A template rig (as a `rigs.Rig`), a sequence of 0/1 expression weights and their examples on it."""

    template: object
    weights: np.ndarray
    examples: np.ndarray


def conformance_case(seed: int = 0) -> _Case:
    """A 12 x 14 sheet with 6 bump blendshapes, and 4 expressions of 0/1 weights with their positions."""
    import rigs

    rng = np.random.default_rng(seed)
    columns, rows, count = 12, 14, 6
    x, y = np.meshgrid(np.linspace(0.0, 1.0, columns), np.linspace(0.0, 1.2, rows))
    z = 0.15 * np.exp(-((x - 0.5) ** 2 + (y - 0.6) ** 2) / 0.08)
    neutral = np.c_[x.ravel(), y.ravel(), z.ravel()]
    grid = np.arange(columns * rows).reshape(rows, columns)
    a, b, c, d = (grid[:-1, :-1].ravel(), grid[:-1, 1:].ravel(), grid[1:, :-1].ravel(), grid[1:, 1:].ravel())
    triangles = np.r_[np.c_[a, b, d], np.c_[a, d, c]]
    centres = rng.uniform([0.2, 0.2], [0.8, 1.0], (count, 2))
    distance = np.linalg.norm(neutral[None, :, :2] - centres[:, None], axis=-1) / 0.3
    directions = rng.normal(size=(count, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    deltas = 0.05 * np.clip(1.0 - distance**2, 0.0, None)[..., None] ** 3 * directions[:, None, :]
    template = rigs.Rig(neutral, deltas, triangles, tuple(f"bump{k}" for k in range(count)))
    weights = np.zeros((4, count))
    for row, shapes in enumerate(([0, 3], [1, 4], [2], [5])):
        weights[row, shapes] = 1.0
    return _Case(template, weights, neutral + np.einsum("jk,knd->jnd", weights, deltas))


def _scale(case: _Case) -> float:
    return float(np.abs(case.template.deltas).max())


def _call(method: Transfer, case: _Case, target: np.ndarray | None = None, *, examples: bool = True):
    neutral = case.template.neutral if target is None else target
    shift = 0.0 if target is None else target - case.template.neutral
    return method(case.template, neutral, case.weights, case.examples + shift if examples else None)


def check_declaration(method: Transfer, seed: int = 0) -> None:
    """A `transfer.Transfer` with a non-empty ``name``, and ``binary_weights`` and ``uses_examples`` bools."""
    assert isinstance(method, Transfer), f"{method!r} is not a transfer.Transfer"
    assert isinstance(method.name, str) and method.name, f"name must be a non-empty str, got {method.name!r}"
    for flag in ("binary_weights", "uses_examples"):
        assert isinstance(getattr(method, flag), bool), f"{flag} must be a bool"


def check_output(method: Transfer, seed: int = 0) -> None:
    """``(K, N, 3)`` finite floats, a new array; the template's arrays are left as they were."""
    case = conformance_case(seed)
    before = case.template.deltas.copy(), case.template.neutral.copy()
    found = _call(method, case)
    assert isinstance(found, np.ndarray), f"returned {type(found).__name__}, not an ndarray"
    assert found.shape == case.template.deltas.shape, f"shape {found.shape}, not {case.template.deltas.shape}"
    assert np.issubdtype(found.dtype, np.floating) and np.isfinite(found).all(), "not finite floats"
    assert not np.shares_memory(found, case.template.deltas), "returned the template's own deltas array"
    assert np.array_equal(case.template.deltas, before[0]), "changed the template's deltas"
    assert np.array_equal(case.template.neutral, before[1]), "changed the template's neutral"


def check_identity(method: Transfer, seed: int = 0) -> None:
    """The template transferred onto its own neutral, with its own expressions, is the template."""
    case = conformance_case(seed)
    error = float(np.abs(_call(method, case) - case.template.deltas).max())
    assert error <= EXACT_TOLERANCE * _scale(case), f"off the template's deltas by {error:.3g}"


def check_translation(method: Transfer, seed: int = 0) -> None:
    """A target that is the template translated gets the template's deltas."""
    case = conformance_case(seed)
    found = _call(method, case, case.template.neutral + np.array([0.3, -1.2, 2.5]))
    error = float(np.abs(found - case.template.deltas).max())
    assert error <= EXACT_TOLERANCE * _scale(case), f"a translated target is off by {error:.3g}"


def check_prefixes(method: Transfer, seed: int = 0) -> None:
    """``prefixes(...)(j)`` is the method called with the first j expressions, for every j."""
    case = conformance_case(seed)
    target = case.template.neutral * np.array([1.1, 0.95, 1.0])
    examples = case.examples * np.array([1.1, 0.95, 1.0])
    first = method.prefixes(case.template, target, case.weights, examples)
    for count in range(len(case.weights) + 1):
        alone = method(case.template, target, case.weights[:count], examples[:count])
        assert np.allclose(first(count), alone, rtol=1e-9, atol=1e-12 * _scale(case)), (
            f"prefixes(...)({count}) differs from a call with the first {count} expressions"
        )


def check_determinism(method: Transfer, seed: int = 0) -> None:
    """Two calls on the same inputs agree bit for bit."""
    case = conformance_case(seed)
    target = case.template.neutral * np.array([1.1, 0.95, 1.0])
    assert np.array_equal(_call(method, case, target), _call(method, case, target)), "two calls differ"


def check_examples(method: Transfer, seed: int = 0) -> None:
    """A method that declares ``uses_examples = False`` gives the same without the examples."""
    if method.uses_examples:
        return
    case = conformance_case(seed)
    target = case.template.neutral * np.array([1.1, 0.95, 1.0])
    with_examples = _call(method, case, target)
    without = method(case.template, target)
    assert np.array_equal(with_examples, without), "declares uses_examples = False but the examples count"


def check_refusal(method: Transfer, seed: int = 0) -> None:
    """A target neutral with another vertex count is a `ValueError` naming the target."""
    case = conformance_case(seed)
    try:
        method(case.template, case.template.neutral[:-1], case.weights, case.examples[:, :-1])
    except ValueError as error:
        assert "target" in str(error).lower(), f"the message does not name the target: {error}"
    else:
        raise AssertionError("a target neutral with another vertex count was accepted")


#: Every conformance check, in the order `check_transfer` runs them.
CHECKS: dict[str, Callable[..., None]] = {
    "declaration": check_declaration,
    "output": check_output,
    "identity": check_identity,
    "translation": check_translation,
    "prefixes": check_prefixes,
    "determinism": check_determinism,
    "examples": check_examples,
    "refusal": check_refusal,
}


def parametrize_with_checks(methods: Iterable[Transfer]):
    """A ``pytest.mark.parametrize`` over every (method, check) pair, as scikit-learn's."""
    return parametrize_checks(CHECKS, methods, "method", lambda method: method.name)


def check_transfer(method: Transfer, *, seed: int = 0) -> list[str]:
    """Run every conformance check on a transfer method (an instance, e.g. ``transfer.get(name)``).

    Returns
    -------
    list of str: the names of the checks that ran (`CHECKS`).

    Raises
    ------
    AssertionError
        On the first failed check, naming it.
    """
    return run_checks(CHECKS, method, seed)
