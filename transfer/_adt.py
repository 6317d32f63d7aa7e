"""Anatomical deformation transfer and anatomical plausibility (Wagner et al. 2024, Algorithm 1, eqs. 5-19).

`Anatomy` holds what one template and one target share: the template aligned to the target (a rotation),
the head template, the fitted heads ``H_S`` and ``H_T`` (eq. 7) with their simulators, and a deformation
transfer of displacement fields between the neutrals. It is made once per (rig, target) pair
(`anatomy`, memoised on content digests) and shared by every call.

The simulated head is coarser than the rig and made from the rig itself (`transfer._head`), so it cannot
take on all of a shape; what it cannot is carried over geometrically, which makes both functions exact
where the paper's are by construction:

- ``adt`` (Algorithm 1) transfers the missing blendshape through the volume: ``invSim`` on ``H_S``,
  ``fc``, ``fwdSim`` on ``H_T`` with the bones' translations scaled by ``BB(T) / BB(S)``; the part of the
  shape the source's inverse simulation leaves (its residual on the rig's vertices) is added by
  deformation transfer. On the template's own neutral, or on a uniformly scaled one, it returns the
  shape, or the scaled shape.
- ``anacon`` (eq. 19) runs ``invSim`` and ``fwdSim`` on ``H_T`` with the characteristics of the source
  expression. The detail of its input that the volume cannot express is kept; what the volume could
  express but the anatomy rejects is replaced by what the anatomy rejects of the source expression itself
  on ``H_S`` (transferred). So an input that is as plausible as the source expression is left as it is,
  an implausible one is corrected, and the source expression on its own neutral comes back unchanged.

The facial characteristics ``fc`` (eqs. 15-17) are taken from the whole source expression, and are asked of
the whole result: the forward simulation's surface is drawn to them less what is carried over after it.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Any

import numpy as np

from registry import BoundedMemo
from transfer._digest import content_digest
from transfer._features import Features, area_ratios, find_features, similarity, triangle_areas
from transfer._frames import TransferredEdges, rigid_rotation
from transfer._head import Head, HeadTemplate, rigid_fit, skin_vertices
from transfer._projective import BATCH, Bones, Simulator, Weights
from transfer._reconstruct import FrameReconstruction

#: Anatomies kept per process (each holds two heads, their factorisations and per-shape source results).
_CACHE_SIZE = 2
_anatomies: BoundedMemo[Anatomy] = BoundedMemo(_CACHE_SIZE)


@dataclass(frozen=True)
class Settings:
    """What the anatomy depends on besides the rig and the target.

    Attributes
    ----------
    resolution : int
        Wanted coarse skin vertices of the head (`transfer._head`).
    iterations : int
        Local-global iterations of every simulation.
    weights : Weights
        Table 3.
    seed : int
        Seed of the head's clusters.
    """

    resolution: int = 1000
    iterations: int = 10
    weights: Weights = Weights()
    seed: int = 0


class FieldTransfer:
    """Deformation transfer of displacement fields from one neutral to another (Sumner & Popovic 2004).

    Each field's edges are transferred through the triangles' deformation gradients and the vertices solved
    by least squares with one vertex per mesh component held (one factorisation for every field); each
    component is then translated so that its mean displacement is the source's times ``scale``. Exact for
    the identity, a translation and a uniform scale by ``scale``.
    """

    def __init__(self, source: np.ndarray, target: np.ndarray, triangles: np.ndarray, scale: float) -> None:
        self.source, self.target, self.triangles, self.scale = source, target, triangles, scale
        reconstruction = FrameReconstruction(target, triangles)
        n_vertices = target.shape[0]
        held = reconstruction.anchored(np.zeros((1, n_vertices), dtype=bool), np.zeros((1, n_vertices)))[0]
        self.block = reconstruction.block(held)
        _, self.component = np.unique(reconstruction.components, return_inverse=True)
        self.counts = np.bincount(self.component)

    def __call__(self, fields: np.ndarray) -> np.ndarray:
        """Transfer ``(B, N, 3)`` displacement fields of the source neutral onto the target's."""
        result = np.zeros_like(fields)
        if self.block is not None and len(fields):
            edges = TransferredEdges(self.source, fields, self.target, self.triangles)
            wanted = edges.block(self.block.faces, np.arange(len(fields)))
            held = np.zeros((self.block.near.size, 3, len(fields)))
            result[:, self.block.free] = np.moveaxis(self.block.solve(wanted, held), -1, 0)
        gap = self.scale * fields - result
        shift = np.stack(
            [np.bincount(self.component, gap[b, :, axis]) for b in range(len(fields)) for axis in range(3)]
        )
        shift = shift.reshape(len(fields), 3, -1).transpose(0, 2, 1) / self.counts[None, :, None]
        return result + shift[:, self.component]


@dataclass
class _SourceShapes:
    """The template shapes simulated on ``H_S`` once (eq. 19's source expressions)."""

    fitted_residual: np.ndarray  # (K, N, 3) the part of its residual the volume could express
    ratios: np.ndarray | None
    contour: np.ndarray | None


class Anatomy:
    """The heads of one template and target, their simulators and transfers (Algorithm 1's fitHead).

    Parameters
    ----------
    template : Rig
    target_neutral : (N, 3) array
    settings : Settings

    Attributes
    ----------
    rotation : (3, 3) array
        Turns the template to face like the target (Kabsch); every field of the template is rotated by it.
    source_neutral, source_deltas : arrays
        The template, rotated.
    features : Features
    head : HeadTemplate
    source, target : Simulator
        On ``H_S`` and ``H_T``.
    scale : float
        ``BB(T) / BB(S)``, the ratio of the skins' bounding-box diagonals.
    """

    def __init__(self, template: Any, target_neutral: np.ndarray, settings: Settings) -> None:
        import rigs

        self.settings = settings
        self.rotation = rigid_rotation(template.neutral, target_neutral)
        self.source_neutral = template.neutral @ self.rotation.T
        self.source_deltas = template.deltas @ self.rotation.T
        self.target_neutral = target_neutral
        self.triangles = template.triangles
        camera = rigs.frontal_camera(template) @ self.rotation.T
        skin = skin_vertices(template.n_vertices, template.triangles)
        self.features: Features = find_features(
            self.source_neutral, template.triangles, skin, camera, dict(template.regions or {})
        )
        self.head = HeadTemplate.build(
            self.source_neutral,
            self.source_deltas,
            template.triangles,
            tuple(template.names),
            camera,
            self.features,
            settings.resolution,
            settings.seed,
        )
        source_head = self.head.fit(self.source_neutral)
        target_head = self.head.fit(target_neutral)
        self.scale = target_head.size / source_head.size
        self.source = self._simulator(source_head)
        self.target = self._simulator(target_head)
        self._transfers: dict[bool, FieldTransfer] = {}
        self._shapes: _SourceShapes | None = None
        self._lock = threading.RLock()

    def _simulator(self, head: Head) -> Simulator:
        return Simulator(self.head, head, self.features, self.settings.weights, self.settings.iterations)

    def transfer(self, forward: bool = True) -> FieldTransfer:
        """Deformation transfer of fields from the source neutral to the target's (or back)."""
        with self._lock:
            found = self._transfers.get(forward)
            if found is None:
                pair = (
                    (self.source_neutral, self.target_neutral)
                    if forward
                    else (self.target_neutral, self.source_neutral)
                )
                scale = self.scale if forward else 1.0 / self.scale
                found = self._transfers[forward] = FieldTransfer(*pair, self.triangles, scale)
            return found

    def bones(self, head: Head, displacements: np.ndarray) -> Bones:
        """Rigid motions of cranium and jaw measured on their skin (Fig. 4) in ``(B, N, 3)`` displacements."""
        parts = []
        for track in (self.head.cranium_track, self.head.jaw_track):
            if track.size == 0:
                count = len(displacements)
                parts.append((np.broadcast_to(np.eye(3), (count, 3, 3)), np.zeros((count, 3))))
            else:
                parts.append(rigid_fit(head.neutral[track], head.neutral[track] + displacements[:, track]))
        return Bones(
            np.stack([parts[0][0], parts[1][0]], axis=1), np.stack([parts[0][1], parts[1][1]], axis=1)
        )

    def characteristics(
        self, simulator: Simulator, surface: np.ndarray, forward: bool
    ) -> tuple[np.ndarray | None, np.ndarray | None]:
        """``fc`` (eqs. 15-17) of ``(B, N, 3)`` displacements on ``simulator``'s neutral, for the other head.

        Returns the eye triangles' area ratios and the lip contour positions ``F_lc`` of the embedded
        contour vertices. Eq. 16 maps the source contour's positions by the similarity that best fits it
        to its deformation transfer (eq. 17); mapping positions would impose the source's lip shape on
        the target even where the lips do not move, so the similarity's scale and rotation map the
        contour's motion instead, added to the other neutral's contour (the same at the identity and
        under a uniform scale).
        """
        if self.settings.weights.characteristics == 0:
            return None, None
        neutral = simulator.head.neutral
        ratios = area_ratios(self.features, neutral, neutral + surface)
        contour = simulator.contour
        if contour.size == 0:
            return ratios, None
        other = self.target_neutral if forward else self.source_neutral
        moved = self.transfer(forward)(surface)
        scale, rotation = similarity(
            neutral[contour] + surface[:, contour], other[contour] + moved[:, contour]
        )
        motion = scale[:, None, None] * surface[:, contour] @ np.swapaxes(rotation, 1, 2)
        return ratios, other[contour] + motion

    def adt(self, displacements: np.ndarray, forward: bool = True) -> np.ndarray:
        """``adt(S_i^M, S, T)`` (eq. 5, Algorithm 1) of ``(B, N, 3)`` source displacements, batched.

        ``forward=False`` transfers from the target to the source (``adt(T_j, T, S)``, eq. 20).

        Returns
        -------
        (B, N, 3) displacements on the other neutral.
        """
        source, target = (self.source, self.target) if forward else (self.target, self.source)
        scale = self.scale if forward else 1.0 / self.scale
        result = np.empty_like(displacements)
        for start in range(0, len(displacements), BATCH):
            part = displacements[start : start + BATCH]
            bones = self.bones(source.head, part)
            volume = source.inverse(part, bones)
            surface = source.surface(volume)
            carried = self.transfer(forward)(part - surface)
            ratios, contour = self.characteristics(source, part, forward)
            neutral = source.head.neutral
            ratios, contour = self._for_volume(ratios, contour, carried, neutral + surface, neutral + part)
            skull = target.skull(bones, scale)
            first = target.head.rest + scale * (volume - source.head.rest)
            moved = target.forward(source._gradients(volume), skull, contour, ratios, first)
            result[start : start + BATCH] = target.surface(moved) + carried
        return result

    def _for_volume(
        self,
        ratios: np.ndarray | None,
        contour: np.ndarray | None,
        carried: np.ndarray,
        simulated: np.ndarray,
        whole: np.ndarray,
    ) -> tuple[np.ndarray | None, np.ndarray | None]:
        """Characteristics for the simulated surface, given those of the whole result (eq. 15-16).

        The result is the simulated surface plus ``carried`` displacements, so the contour the volume
        must reach is ``F_lc`` less what is carried, and each eye triangle's area ratio is scaled by how
        much smaller the simulated surface (``simulated`` positions) has it than the whole (``whole``).
        """
        if ratios is not None:
            triangles = self.features.area_triangles
            ratios = ratios * _area_ratio(simulated, whole, triangles)
        if contour is not None:
            contour = contour - carried[:, self.source.contour]
        return ratios, contour

    def source_shapes(self) -> _SourceShapes:
        """The template's shapes simulated once on ``H_S`` (``invSim(S_i, H_S)`` and ``fc(S_i, S, T)``)."""
        with self._lock:
            if self._shapes is None:
                deltas = self.source_deltas
                surface = np.empty_like(deltas)
                fitted = np.empty_like(deltas)
                ratios, contours = [], []
                for start in range(0, len(deltas), BATCH):
                    part = deltas[start : start + BATCH]
                    volume = self.source.inverse(part, self.bones(self.source.head, part))
                    surface[start : start + BATCH] = self.source.surface(volume)
                    fitted[start : start + BATCH] = self.source.linear_fit(
                        part - surface[start : start + BATCH]
                    )
                    found = self.characteristics(self.source, part, True)
                    ratios.append(found[0])
                    contours.append(found[1])
                self._shapes = _SourceShapes(
                    fitted,
                    None if ratios[0] is None else np.concatenate(ratios),
                    None if contours[0] is None else np.concatenate(contours),
                )
            return self._shapes

    def anacon(self, displacements: np.ndarray) -> np.ndarray:
        """``anacon(T_i^P + T_i^M hat, S_i, S, T)`` (eqs. 6, 19) of the K shapes' ``(K, N, 3)`` target
        displacements, with the characteristics of the template's K shapes."""
        shapes = self.source_shapes()
        transferred = self.transfer(True)(shapes.fitted_residual)
        result = np.empty_like(displacements)
        for start in range(0, len(displacements), BATCH):
            part = slice(start, start + BATCH)
            goal = displacements[part]
            volume = self.target.inverse(goal, self.bones(self.target.head, goal))
            surface = self.target.surface(volume)
            residual = goal - surface
            carried = residual - self.target.linear_fit(residual) + transferred[part]
            neutral = self.target_neutral
            ratios, contour = self._for_volume(
                None if shapes.ratios is None else shapes.ratios[part],
                None if shapes.contour is None else shapes.contour[part],
                carried,
                neutral + surface,
                neutral + goal,
            )
            moved = self.target.forward(
                self.target._gradients(volume), volume[:, self.target.fixed], contour, ratios, volume
            )
            result[part] = self.target.surface(moved) + carried
        return result


def _area_ratio(numerator: np.ndarray, denominator: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """``A(numerator, f) / A(denominator, f)`` per triangle, 1 where the denominator's area is zero."""
    top, bottom = triangle_areas(numerator, triangles), triangle_areas(denominator, triangles)
    valid = bottom > 0
    return np.where(valid, top / np.where(valid, bottom, 1.0), 1.0)


def anatomy(template: Any, target_neutral: np.ndarray, settings: Settings) -> Anatomy:
    """The `Anatomy` of a template rig and a target neutral, memoised per process on their content."""
    regions = dict(template.regions or {})
    digest = content_digest(
        template.neutral,
        template.deltas,
        template.triangles,
        target_neutral,
        *(regions[k] for k in sorted(regions)),
    ) + repr((tuple(template.names), sorted(regions)))
    return _anatomies.get_or_build((digest, settings), lambda: Anatomy(template, target_neutral, settings))
