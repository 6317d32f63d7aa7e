"""Deformation transfer of every template shape onto the target neutral (Sumner & Popovic 2004)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from transfer._base import Transfer, check_positive
from transfer._inputs import TransferInputs
from transfer._setup import TransferSetup, transfer_setup


def deformation_transfer(
    template_neutral: np.ndarray,
    template_deltas: np.ndarray,
    target_neutral: np.ndarray,
    triangles: np.ndarray,
    *,
    static_tolerance: float = 1e-6,
    align: bool = True,
) -> np.ndarray:
    """Transfer delta blendshapes from a template neutral to a target neutral.

    Each template triangle's deformation gradient ``M(A0 + A_k) M(A0)^-1`` (frames with the scaled
    normal) is applied to the target neutral's triangle, and the target vertices are found by least
    squares on the resulting edges (see `FrameReconstruction`).

    Parameters
    ----------
    template_neutral : (N, 3) array
    template_deltas : (K, N, 3) array
    target_neutral : (N, 3) array
    triangles : (T, 3) int array
    static_tolerance : float
        Vertices moving at most this fraction of a shape's largest displacement keep the template's
        displacement (Li et al. 2010, sec. 3A: static vertices stay fixed).
    align : bool
        Rotate the template to face like the target first (Kabsch), so a global rigid motion between
        the two characters does not bend the transferred gradients.

    Returns
    -------
    (K, N, 3) array of target deltas.

    Notes
    -----
    O(T + K N) plus, per distinct set of static vertices, the gradients of the triangles around its
    free vertices and one sparse factorisation, reused for all three coordinates and every shape
    sharing it (see `TransferSetup`).
    """
    setup = TransferSetup(
        template_neutral,
        template_deltas,
        triangles,
        target_neutral,
        static_tolerance=static_tolerance,
        align=align,
        factor_budget=0,
    )
    return setup.transfer_all()


@dataclass(frozen=True)
class DeformationTransfer(Transfer):
    """Deformation transfer of every template shape onto the target neutral; no training data.

    Parameters
    ----------
    static_tolerance : float, default 1e-6
        Relative displacement below which a vertex counts as static and is held.
    align : bool, default True
        Remove a global rotation between template and target before transferring.

    Examples
    --------
    >>> import transfer
    >>> deltas = transfer.get("dt")(template, target.neutral)  # doctest: +SKIP

    Notes
    -----
    Sumner & Popovic 2004; the training expressions are ignored. Exact when the target is a rigid
    motion of the template.
    """

    name: ClassVar[str] = "dt"
    uses_examples: ClassVar[bool] = False
    static_tolerance: float = 1e-6
    align: bool = True

    def __post_init__(self) -> None:
        check_positive(self.static_tolerance, "static_tolerance", allow_zero=True)

    def transfer(self, inputs: TransferInputs) -> np.ndarray:
        """Transfer every template shape; see `deformation_transfer`.

        The result comes from the memoised `transfer_setup` of the rig pair, which `transfer.ebfr`
        shares: shapes in no training expression are exactly this transfer.
        """
        setup = transfer_setup(
            inputs.template, inputs.target_neutral, static_tolerance=self.static_tolerance, align=self.align
        )
        return setup.transferred.copy()
