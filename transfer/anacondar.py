"""AnaConDaR: anatomically-constrained data-adaptive facial retargeting (Wagner, Schwanecke, Botsch 2024)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from transfer._base import Transfer, check_positive
from transfer._frames import vertex_major
from transfer._inputs import TransferInputs, check_inputs, check_weights
from transfer.deformation import deformation_transfer
from transfer.plbs import patch_blendshapes

#: Vertices of the paper's skin (Table 2): the data term of eq. 2 counts each rig vertex as this many over
#: the rig's vertex count, so that Table 3's ``lambda_reg`` means the same on a coarser or finer rig.
PAPER_SKIN_VERTICES = 29_826
#: Goals retargeted at once (bounds the few ``(chunk, N, 3)`` arrays of a call beside its result).
_GOAL_CHUNK = 64
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

    The target examples take precedence over ``anacon``: its characteristics and anatomy constrain what
    the examples do not determine (`transfer._adt.Explained`), so with every shape its own example the
    method returns the target's shapes (relative RMS 1.3e-4 on the tests' warped ``tiny``, 1.0e-2 on
    ``toon`` with ``alien+character``, where deformation transfer misses by 0.34), and without examples it
    is the paper's.

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
        Ridge weight of eq. 2 (Table 3). The data term is counted as on the paper's skin: positions in
        millimetres of a face scaled to a 30 cm skin diagonal (the paper reports millimetres), and each
        rig vertex weighing `PAPER_SKIN_VERTICES` / N, so that a patch counts as many vertices as the
        paper's (Table 2). The paper gives no unit; this reading keeps the examples' own shapes (every
        shape its own example reproduces the target) but lets a few random examples explain a shape they
        miss by inflating small motions of others, which the target amplifies; ``lambda_reg=900`` (the
        same 0.01 with positions in 30 cm face diagonals) stops that and loses the examples' detail
        (Fig. 10's protocol, ``harness run --preset fig10``, measures both).
    adt : {"adt", "dt"}, default "adt"
        How the missing blendshape is transferred: anatomically, or by Sumner & Popovic's deformation
        transfer (the ablation of sec. 4.5).
    characteristics : bool, default True
        Keep the facial characteristics (eqs. 15-17) in the forward simulations (``w_F = 10``).
    missing : bool, default True
        Add the missing blendshape (eq. 6); ``False`` retargets ``anacon(T_i^P)`` only.
    anacon : bool, default True
        Make the sum plausible by ``anacon`` (eqs. 6, 19). ``anacondar[missing=off,anacon=off]`` is the
        patchwise blend ``T_i^P`` alone: Chandran et al.'s anatomical local model (ALM) as Wagner et al.
        compare it (secs. 4.2, 4.4), the same PLBS as AnaConDaR's, without ALM's own data-driven surface
        constraints. The paper pairs each target example with a source example through EBFR's rigs; the
        harness knows the examples' weights, so the source example is the template at those weights.
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
    forward simulations per shape, and an inverse simulation of each training expression on both heads
    (memoised, so a rising J simulates each once). Without training expressions the data-driven part is
    empty and the result is ``anacon(adt(S_i))``. `retarget` takes the frames of a source animation
    instead of the template's shapes.
    """

    name: ClassVar[str] = "anacondar"
    n_patches: int = 80
    blend_rings: int = 3
    lambda_reg: float = 0.01
    adt: str = "adt"
    characteristics: bool = True
    missing: bool = True
    anacon: bool = True
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
        for field in ("characteristics", "missing", "anacon", "embed"):
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
        return self._retarget(inputs, inputs.template.deltas, frames=False)

    def retarget(
        self,
        template: object,
        target_neutral: object,
        weights: object = None,
        examples: object = None,
        frames: object = None,
    ) -> np.ndarray:
        """Eq. 6 for the frames of a source animation: each frame ``S_i`` retargeted as a whole.

        The paper retargets an animation frame by frame (sec. 3.1); a frame that mixes several template
        shapes is not the mix of their retargetings, as ``adt`` and ``anacon`` are not linear. This is
        the call of its quantitative evaluation (sec. 4.4, Fig. 10).

        Parameters
        ----------
        template, target_neutral, weights, examples
            As for calling the method.
        frames : (F, K) array
            Template shape weights of the source frames.

        Returns
        -------
        (F, N, 3) array: the retargeted frames' displacements from the target neutral.
        """
        inputs = check_inputs(template, target_neutral, weights, examples, method=self.name)
        frames = check_weights(frames, inputs.template.n_shapes, argument="frames")
        return self._retarget(inputs, np.tensordot(frames, inputs.template.deltas, axes=1), frames=True)

    def _retarget(self, inputs: TransferInputs, goals: np.ndarray, *, frames: bool) -> np.ndarray:
        """Eq. 6 for ``(B, N, 3)`` source displacements ``goals``: the template's shapes (whose
        `transfer._adt.SourceTerms` the anatomy keeps), or ``frames`` of an animation; `_GOAL_CHUNK` goals
        at a time, so that memory stays a few ``(chunk, N, 3)`` arrays beside the result."""
        from transfer._embedding import embed_examples
        from transfer._projective import FACE_DIAGONAL

        needed = self.anacon or self.embed or (self.missing and self.adt == "adt")
        anatomy = self.anatomy(inputs) if needed else None
        template = inputs.template
        density = np.sqrt(template.n_vertices / PAPER_SKIN_VERTICES)
        scale = (template.diagonal() or 1.0) / FACE_DIAGONAL * density
        weights = inputs.weights
        offsets = inputs.examples - inputs.target_neutral
        if self.embed and len(offsets):
            weights = embed_examples(anatomy, offsets, self.lambda_reg, scale)
        terms = None
        if self.anacon:
            terms = anatomy.source_terms(goals @ anatomy.rotation.T) if frames else anatomy.source_shapes()
        examples = _Examples(self, anatomy, template, weights, offsets, scale) if len(weights) else None
        result = np.empty(goals.shape)
        for start in range(0, len(goals), _GOAL_CHUNK):
            rows = slice(start, start + _GOAL_CHUNK)
            goal = goals[rows]
            data_driven, missing, explained = np.zeros_like(result[rows]), goal, None
            if examples is not None:
                data_driven, missing, explained = examples.explain(goal)
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
            result[rows] = anatomy.anacon(combined, terms.part(rows), explained) if self.anacon else combined
        return result


class _Examples:
    """The data-driven part of eq. 6 for any goals: patchwise blendshapes of the training examples
    (eqs. 1-3), with what the anatomy rejects of the examples blended alike for ``anacon``.

    Parameters
    ----------
    method : AnaConDaR
    anatomy : transfer._adt.Anatomy or None
        Needed when ``method.anacon``.
    template : Rig
    weights : (J, K) array
        The examples' template weights (the source examples are the template at them).
    offsets : (J, N, 3) array
        The target examples' displacements.
    scale : float
        Length unit of eq. 2's data term.
    """

    def __init__(
        self,
        method: AnaConDaR,
        anatomy: Any,
        template: Any,
        weights: np.ndarray,
        offsets: np.ndarray,
        scale: float,
    ) -> None:
        from transfer._partition import metis_partition
        from transfer._patches import blend_weights

        labels = metis_partition(template.neutral, template.triangles, method.n_patches, seed=method.seed)
        self.blend = blend_weights(labels, template.triangles, method.blend_rings)
        self.lambda_reg, self.scale, self.anatomy = method.lambda_reg, scale, anatomy
        self.sources = np.tensordot(weights, template.deltas, axes=1)
        self.fields = [offsets]
        if method.anacon:
            rotation = anatomy.rotation.T
            self.fields += [
                anatomy.rejected(self.sources @ rotation),
                anatomy.rejected(offsets, on_target=True),
            ]

    def explain(self, goals: np.ndarray) -> tuple[np.ndarray, np.ndarray, Any]:
        """``T_i^P - T`` (eq. 3), the missing blendshapes ``S_i - S_i^P`` (eq. 4) and, with ``anacon``,
        what the examples explain of ``(B, N, 3)`` goals (a `transfer._adt.Explained`, else None)."""
        from transfer._adt import Explained

        found = [
            patch_blendshapes(
                _major(self.sources),
                _major(field),
                vertex_major(goals),
                self.blend,
                self.lambda_reg,
                self.scale,
            )
            for field in self.fields
        ]
        source, data_driven = found[0]
        if len(found) == 1:
            return data_driven, goals - source, None
        rotation = self.anatomy.rotation.T
        explained = Explained(source @ rotation, data_driven, found[1][1], found[2][1])
        return data_driven, goals - source, explained


def _major(fields: np.ndarray) -> np.ndarray:
    """``(J, N, 3)`` fields as the vertex-major ``(N, J, 3)`` of `transfer.plbs.patch_blendshapes`."""
    return np.ascontiguousarray(fields.transpose(1, 0, 2))
