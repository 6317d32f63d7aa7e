"""The trivial baseline: copy the template's displacements to the target."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from transfer._base import Transfer
from transfer._inputs import TransferInputs


@dataclass(frozen=True)
class DeltaTransfer(Transfer):
    """Per-vertex delta copy: ``B_k - B0 = A_k - A0``.

    Exact when the target is a translated template; the floor every other method must beat.

    Examples
    --------
    >>> import transfer
    >>> deltas = transfer.get("delta")(template, target.neutral)  # doctest: +SKIP

    Notes
    -----
    O(K N).
    """

    name: ClassVar[str] = "delta"
    uses_examples: ClassVar[bool] = False

    def transfer(self, inputs: TransferInputs) -> np.ndarray:
        """Return a writable copy of the template deltas."""
        return np.array(inputs.template.deltas, dtype=np.float64)
