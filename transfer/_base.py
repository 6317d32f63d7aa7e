"""The interface every transfer plugin implements: checked inputs in, K personalised deltas out."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import ClassVar

import numpy as np

from transfer._inputs import TransferInputs, check_count, check_inputs


class Transfer(ABC):
    """A blendshape transfer method (Carrigan et al. 2020, sec. 3, eq. 1).

    Subclasses are frozen dataclasses whose fields are the method's parameters, and implement
    `transfer`. Calling an instance checks the arguments once for every method.

    Attributes
    ----------
    name : str
        The entry-point name in the ``harness.transfers`` group.
    binary_weights : bool
        Whether the method requires 0/1 expression weights.
    uses_examples : bool
        Whether the training expressions influence the result.
    """

    name: ClassVar[str]
    binary_weights: ClassVar[bool] = False
    uses_examples: ClassVar[bool] = True

    def __call__(
        self,
        template: object,
        target_neutral: object,
        weights: object = None,
        examples: object = None,
    ) -> np.ndarray:
        """Personalised blendshapes of the target.

        Parameters
        ----------
        template : Rig
            Template rig A (neutral, K delta blendshapes, triangles).
        target_neutral : (N, 3) array or Rig
            Neutral B0 of the target, on the template's topology.
        weights : (J, K) array, optional
            Blendshape weights of the J training expressions (none when omitted).
        examples : (J, N, 3) array, optional
            The target's training expressions as absolute positions (see `training_expressions`).

        Returns
        -------
        (K, N, 3) array: the target's delta blendshapes ``B_k - B0``.

        Raises
        ------
        ValueError or RigError
            On inputs of the wrong shape or topology, non-finite values, or non-binary weights
            for a method that needs 0/1 weights; the message names the argument and shape.
        """
        inputs = check_inputs(
            template, target_neutral, weights, examples, method=self.name, binary=self.binary_weights
        )
        return self.transfer(inputs)

    def prefixes(
        self,
        template: object,
        target_neutral: object,
        weights: object = None,
        examples: object = None,
    ) -> Callable[[int], np.ndarray]:
        """The method trained on the first J training expressions, as a function of J.

        Carrigan et al. (2020, sec. 5.2) evaluate a sequence of expressions by its first J for several J;
        ``prefixes(...)(j)`` equals calling the method with ``weights[:j]`` and ``examples[:j]``, with the
        arguments checked once, and a method may reuse work between calls (`transfer.ebfr` fits each
        expression once for a rising J).

        Parameters
        ----------
        template, target_neutral, weights, examples
            As for calling the method, with every expression of the sequence.

        Returns
        -------
        Callable ``j -> (K, N, 3)`` deltas for ``0 <= j <= J``; each call returns a new array.

        Raises
        ------
        ValueError or RigError
            As for calling the method; the returned function raises a `ValueError` for a j out of range.
        """
        inputs = check_inputs(
            template, target_neutral, weights, examples, method=self.name, binary=self.binary_weights
        )
        estimate = self._prefixes(inputs)

        def first(count: int) -> np.ndarray:
            check_count(count, inputs.weights.shape[0])
            return estimate(count)

        return first

    def _prefixes(self, inputs: TransferInputs) -> Callable[[int], np.ndarray]:
        """`prefixes` on checked inputs; by default one independent `transfer` per call."""
        return lambda count: self.transfer(inputs.first(count))

    @abstractmethod
    def transfer(self, inputs: TransferInputs) -> np.ndarray:
        """The method itself, on checked inputs; returns ``(K, N, 3)`` deltas."""


def check_positive(value: float, argument: str, *, allow_zero: bool = False) -> None:
    """Raise a `ValueError` naming ``argument`` unless ``value`` is a finite positive number."""
    if not np.isfinite(value) or value < 0 or (value == 0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"{argument} must be a finite number {bound}, got {value!r}")
