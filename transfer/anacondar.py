"""AnaConDaR: anatomically-constrained data-adaptive facial retargeting (Wagner, Schwanecke, Botsch 2024)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from transfer._base import Transfer, check_positive
from transfer._frames import vertex_major
from transfer._inputs import TransferInputs
from transfer._projective import FACE_DIAGONAL
from transfer.deformation import deformation_transfer
from transfer.plbs import patch_blendshapes

#: The transfers of the missing blendshape (sec. 4.5's ablation: ``dt`` instead of ``adt``).
MISSING_TRANSFERS = ("adt", "dt")


@dataclass(frozen=True)
class AnaConDaR(Transfer):
    """Patchwise blendshapes, the missing blendshape by anatomical transfer, then anatomy (Wagner 2024).

    For each template shape ``S_i`` (sec. 3.2): patchwise ridge weights of the template's training
    expressions approximate it (``S_i^P``, eqs. 1-2, `transfer.plbs.patch_blendshapes`) and, applied to the
    target's expressions, give the data-driven part ``T_i^P`` (eq. 3); the missing blendshape
    ``S_i - S_i^P`` (eq. 4) is transferred by anatomical deformation transfer (eq. 5, Algorithm 1,
    `transfer._adt`); their sum passes through ``anacon`` (eqs. 6, 19), the inverse and forward
    simulations on the target's head with the source expression's facial characteristics.

    The head is not the paper's CT template: it is made from the rig itself (a skull offset inward by a
    regional tissue thickness, soft tissue and muscle as prism layers of tetrahedra, see `transfer._head`),
    on a coarser skin than the rig's, and what that volume cannot express of a shape is carried over by
    deformation transfer; so the method is exact on the template's own neutral with its own expressions.

    Parameters
    ----------
    n_patches : int, default 80
        Patches of the METIS layout (Fig. 1).
    blend_rings : int, default 3
        Patch weights are averaged over this many rings (see `transfer._patches.blend_weights`). The paper
        uses hard patches (0) and lets ``anacon`` remove their seams on its fine tetrahedral skin; the
        coarse head here cannot, so the patches are blended as in ``plbs``.
    lambda_reg : float, default 0.01
        Ridge weight of eq. 2 (Table 3), positions in millimetres of a face scaled to a 30 cm skin
        diagonal (the paper's unit; measured in whole diagonals, as ``plbs`` does, the ridge would
        outweigh the data on a coarse rig).
    adt : {"adt", "dt"}, default "adt"
        How the missing blendshape is transferred: anatomically, or by Sumner & Popovic's deformation
        transfer (the ablation of sec. 4.5).
    characteristics : bool, default True
        Keep the facial characteristics (eqs. 15-17) in the forward simulations (``w_F = 10``).
    missing : bool, default True
        Add the missing blendshape (eq. 6); ``False`` retargets ``anacon(T_i^P)`` only.
    embed : bool, default False
        Ignore the given weights and embed the examples in the source domain instead (sec. 3.5,
        eqs. 20-21), as for target examples with no known source expression.
    resolution : int, default 1000
        Wanted number of coarse skin vertices of the simulated head.
    iterations : int, default 8
        Local-global iterations of each projective-dynamics simulation.
    seed : int, default 0
        Seed of the patch layout and of the head's clusters.
    static_tolerance : float, default 1e-6
        Static threshold of the deformation transfer with ``adt="dt"``.

    Examples
    --------
    >>> import transfer
    >>> deltas = transfer.get("anacondar")(template, target.neutral, weights, examples)  # doctest: +SKIP

    Notes
    -----
    The head (fit, factorisations, the template's shapes simulated on it) is made once per template and
    target and shared by every call (`transfer._adt.anatomy`); a call then costs two inverse and two
    forward simulations per shape. Without training expressions the data-driven part is empty and the
    result is ``anacon(adt(S_i))``.
    """

    name: ClassVar[str] = "anacondar"
    n_patches: int = 80
    blend_rings: int = 3
    lambda_reg: float = 0.01
    adt: str = "adt"
    characteristics: bool = True
    missing: bool = True
    embed: bool = False
    resolution: int = 1000
    iterations: int = 8
    seed: int = 0
    static_tolerance: float = 1e-6

    def __post_init__(self) -> None:
        for field, least in (("n_patches", 1), ("blend_rings", 0), ("resolution", 4), ("iterations", 1)):
            value = getattr(self, field)
            if isinstance(value, bool) or int(value) != value or value < least:
                raise ValueError(f"{field} must be an integer >= {least}, got {value!r}")
        if self.adt not in MISSING_TRANSFERS:
            raise ValueError(f"adt must be one of {', '.join(MISSING_TRANSFERS)}, got {self.adt!r}")
        for field in ("characteristics", "missing", "embed"):
            if not isinstance(getattr(self, field), bool):
                raise ValueError(f"{field} must be on or off (a bool), got {getattr(self, field)!r}")
        check_positive(self.lambda_reg, "lambda_reg")
        check_positive(self.static_tolerance, "static_tolerance", allow_zero=True)

    def anatomy(self, inputs: TransferInputs):
        """The memoised `transfer._adt.Anatomy` of the inputs' template and target neutral."""
        from transfer._adt import Settings, anatomy
        from transfer._projective import Weights

        weights = Weights() if self.characteristics else Weights(characteristics=0.0)
        settings = Settings(int(self.resolution), int(self.iterations), weights, int(self.seed))
        return anatomy(inputs.template, inputs.target_neutral, settings)

    def transfer(self, inputs: TransferInputs) -> np.ndarray:
        """Eq. 6 for every template shape."""
        from transfer._embedding import embed_examples
        from transfer._partition import metis_partition
        from transfer._patches import blend_weights

        template = inputs.template
        anatomy = self.anatomy(inputs)
        scale = (template.diagonal() or 1.0) / FACE_DIAGONAL
        weights = inputs.weights
        offsets = inputs.examples - inputs.target_neutral
        if self.embed and len(offsets):
            weights = embed_examples(anatomy, offsets, self.lambda_reg, scale)
        data_driven = np.zeros_like(template.deltas, dtype=np.float64)
        missing = template.deltas
        if len(weights):
            labels = metis_partition(template.neutral, template.triangles, self.n_patches, seed=self.seed)
            source, data_driven = patch_blendshapes(
                np.ascontiguousarray(np.tensordot(weights, template.deltas, axes=1).transpose(1, 0, 2)),
                np.ascontiguousarray(offsets.transpose(1, 0, 2)),
                vertex_major(template.deltas),
                blend_weights(labels, template.triangles, self.blend_rings),
                self.lambda_reg,
                scale,
            )
            missing = template.deltas - source
        combined = data_driven
        if self.missing:
            if self.adt == "adt":
                transferred = anatomy.adt(missing @ anatomy.rotation.T)
            else:
                transferred = deformation_transfer(
                    template.neutral,
                    missing,
                    inputs.target_neutral,
                    template.triangles,
                    static_tolerance=self.static_tolerance,
                )
            combined = combined + transferred
        return anatomy.anacon(combined)
