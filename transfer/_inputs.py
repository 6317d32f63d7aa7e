"""Validation of the arguments every transfer method takes (one clear error per bad input)."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from rigs import Rig


@dataclass(frozen=True)
class TransferInputs:
    """Checked, float64 arguments of a transfer call.

    Attributes
    ----------
    template : Rig
        The template rig A with K blendshapes on N vertices.
    target_neutral : (N, 3) array
        The target's neutral B0.
    weights : (J, K) array
        Blendshape weights of the J training expressions (J may be 0).
    examples : (J, N, 3) array
        The target's training expressions as absolute vertex positions.
    """

    template: Rig
    target_neutral: np.ndarray
    weights: np.ndarray
    examples: np.ndarray

    def first(self, count: int) -> TransferInputs:
        """The same inputs with only the first ``count`` training expressions (see `check_count`)."""
        check_count(count, self.weights.shape[0])
        return replace(self, weights=self.weights[:count], examples=self.examples[:count])


def check_count(count: object, n_expressions: int) -> None:
    """Raise a `ValueError` unless ``count`` is an integer in ``[0, n_expressions]``."""
    if isinstance(count, bool) or not isinstance(count, int | np.integer) or not 0 <= count <= n_expressions:
        raise ValueError(
            f"the number of expressions must be an integer in [0, {n_expressions}], got {count!r}"
        )


def _first_non_finite(array: np.ndarray) -> str:
    index = tuple(int(i) for i in np.argwhere(~np.isfinite(array))[0])
    return f"{list(index)}" if len(index) > 1 else f"{index[0]}"


def as_float_array(value: object, argument: str) -> np.ndarray:
    """``value`` as a finite float64 array; a `ValueError` names ``argument`` and the first bad entry."""
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{argument} must be a numeric array: {error}") from None
    if not np.isfinite(array).all():
        raise ValueError(f"{argument} has a non-finite value at index {_first_non_finite(array)}")
    return array


def check_weights(weights: object, n_shapes: int, *, argument: str = "weights") -> np.ndarray:
    """Expression weights as a finite ``(J, K)`` float array with ``K == n_shapes``.

    ``None`` means no training expressions, ``(0, K)``.
    """
    if weights is None:
        return np.zeros((0, n_shapes))
    array = as_float_array(weights, argument)
    if array.ndim != 2 or array.shape[1] != n_shapes:
        raise ValueError(
            f"{argument} must have shape (J, {n_shapes}) (a column per template shape), got {array.shape}"
        )
    return array


def check_binary(weights: np.ndarray, method: str, *, argument: str = "weights") -> None:
    """Raise a `ValueError` naming the first entry of ``weights`` that is neither 0 nor 1."""
    bad = (weights != 0) & (weights != 1)
    if bad.any():
        j, k = (int(i) for i in np.argwhere(bad)[0])
        raise ValueError(
            f"{argument} must be 0 or 1 for {method!r} (known binary weights); "
            f"{argument}[{j}, {k}] = {float(weights[j, k])!r}"
        )


def check_positions(positions: object, n_vertices: int, argument: str) -> np.ndarray:
    """One mesh's vertex positions as a finite ``(N, 3)`` float array with ``N == n_vertices``."""
    array = as_float_array(positions, argument)
    if array.shape != (n_vertices, 3):
        raise ValueError(
            f"{argument} must have shape ({n_vertices}, 3) (the template's topology), got {array.shape}"
        )
    return array


def check_inputs(
    template: object,
    target_neutral: object,
    weights: object = None,
    examples: object = None,
    *,
    method: str,
    binary: bool = False,
) -> TransferInputs:
    """Check the arguments of a transfer call and return them as float arrays.

    Parameters
    ----------
    template : Rig
        Template rig A.
    target_neutral : (N, 3) array or Rig
        Target neutral B0; a rig is accepted when its triangles equal the template's.
    weights : (J, K) array or None
        Weights of the training expressions; ``None`` for none.
    examples : (J, N, 3) array or None
        Training expressions of the target as absolute positions; ``None`` for none.
    method : str
        Name of the calling method, used in messages.
    binary : bool
        Whether ``weights`` must be 0/1.

    Returns
    -------
    TransferInputs

    Raises
    ------
    ValueError
        Wrong type, wrong shape, non-finite values or non-binary weights; the message names the
        argument and the offending shape or entry.
    RigError
        ``target_neutral`` is a rig with other triangles than the template.
    """
    from rigs import Rig, RigError

    if not isinstance(template, Rig):
        raise ValueError(f"template must be a rigs.Rig, got {type(template).__name__}")
    n_vertices = template.n_vertices
    if isinstance(target_neutral, Rig):
        if target_neutral.triangles.shape != template.triangles.shape or not np.array_equal(
            target_neutral.triangles, template.triangles
        ):
            raise RigError(
                f"target_neutral: rig with {target_neutral.n_vertices} vertices and triangles "
                f"{target_neutral.triangles.shape} does not share the template's topology "
                f"({n_vertices} vertices, triangles {template.triangles.shape})"
            )
        target_neutral = target_neutral.neutral
    neutral = check_positions(target_neutral, n_vertices, "target_neutral")
    weight_array = check_weights(weights, template.n_shapes)
    if binary:
        check_binary(weight_array, method)
    n_expressions = weight_array.shape[0]
    if examples is None:
        if n_expressions:
            raise ValueError(f"examples is missing but weights has {n_expressions} rows (one per example)")
        example_array = np.zeros((0, n_vertices, 3))
    else:
        example_array = as_float_array(examples, "examples")
        if example_array.shape == (0,):
            example_array = example_array.reshape(0, n_vertices, 3)
        if example_array.ndim != 3 or example_array.shape[1:] != (n_vertices, 3):
            raise ValueError(
                f"examples must have shape (J, {n_vertices}, 3) (absolute positions on the template's "
                f"topology), got {example_array.shape}"
            )
        if example_array.shape[0] != n_expressions:
            raise ValueError(
                f"examples holds {example_array.shape[0]} expressions but weights has {n_expressions} rows "
                f"(shape {weight_array.shape}); they must match"
            )
    return TransferInputs(template, neutral, weight_array, example_array)
