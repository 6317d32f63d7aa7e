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
  express but the anatomy rejects is replaced by what the anatomy rejects of a plausible expression of
  the target: of the target's own examples where they explain the source expression (their rejections
  blended by the same patch weights as the data-driven part, `Explained`), and of the source expression
  itself, transferred, for the rest. So an input that is as plausible as the source expression is left as
  it is, an implausible one is corrected, the source expression on its own neutral comes back unchanged,
  and so does a target expression the examples determine.

The facial characteristics ``fc`` (eqs. 15-17) are taken from the whole source expression, and are asked of
the whole result: the forward simulation's surface is drawn to them less what is carried over after it. In
``anacon`` they constrain what the examples do not determine: the lip contour is the data-driven part's
contour plus the similarity-mapped motion the examples do not explain, and each eye triangle's area is the
data-driven part's area times the ratio of the source expression's area to its explained part's. Without
examples this is the paper's ``fc`` (eqs. 15-16); with every shape its own example, the examples' shapes.
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
#: Rejections (`Anatomy.rejected`) an anatomy keeps: a few sessions' examples on both heads.
_REJECTED_SIZE = 128


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


@dataclass(frozen=True)
class SourceTerms:
    """What ``anacon`` takes from B source expressions simulated on ``H_S`` (eq. 19).

    Attributes
    ----------
    displacements : (B, N, 3) array
        The source expressions ``S_i - S``, the template turned to face like the target.
    rejected : (B, N, 3) array
        What the anatomy rejects of each (`Anatomy.rejected`).
    ratios : (B, F) array or None
        ``A(S_i, f) / A(S, f)`` of the eye triangles (eq. 15).
    scale, rotation : (B,) and (B, 3, 3) arrays, or None
        The similarity of eq. 17 that best maps each expression's lip contour onto its deformation
        transfer.
    """

    displacements: np.ndarray
    rejected: np.ndarray
    ratios: np.ndarray | None
    scale: np.ndarray | None
    rotation: np.ndarray | None

    def part(self, rows: slice) -> SourceTerms:
        """The terms of the expressions in ``rows``."""
        return SourceTerms(*(None if value is None else value[rows] for value in vars(self).values()))


@dataclass(frozen=True)
class Explained:
    """What the target examples determine of B source expressions (PLBS, eqs. 1-3), for ``anacon``.

    Attributes
    ----------
    source, target : (B, N, 3) arrays
        ``S_i^P - S`` (the template turned to face like the target) and ``T_i^P - T``.
    source_rejected, target_rejected : (B, N, 3) arrays
        The same patch weights applied to what the anatomy rejects of the examples on ``H_S`` and on
        ``H_T`` (`Anatomy.rejected`).
    """

    source: np.ndarray
    target: np.ndarray
    source_rejected: np.ndarray
    target_rejected: np.ndarray

    def part(self, rows: slice) -> Explained:
        """What is explained of the expressions in ``rows``."""
        return Explained(*(value[rows] for value in vars(self).values()))


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
        self._shapes: SourceTerms | None = None
        self._rejected: BoundedMemo[np.ndarray] = BoundedMemo(_REJECTED_SIZE)
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

    def similarity(
        self, simulator: Simulator, surface: np.ndarray, forward: bool
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """Scale and rotation of eq. 17 for ``(B, N, 3)`` displacements on ``simulator``'s neutral: the
        similarity that best maps their lip contour onto its deformation transfer to the other neutral
        (None without characteristics or a contour)."""
        contour = simulator.contour
        if self.settings.weights.characteristics == 0 or contour.size == 0:
            return None
        other = self.target_neutral if forward else self.source_neutral
        moved = self.transfer(forward)(surface)
        neutral = simulator.head.neutral
        return similarity(neutral[contour] + surface[:, contour], other[contour] + moved[:, contour])

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
        found = self.similarity(simulator, surface, forward)
        if found is None:
            return ratios, None
        other = self.target_neutral if forward else self.source_neutral
        return ratios, other[simulator.contour] + _mapped(found, surface[:, simulator.contour])

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

    def rejected(self, displacements: np.ndarray, on_target: bool = False) -> np.ndarray:
        """What the anatomy rejects of ``(B, N, 3)`` displacements on ``H_S`` (or ``H_T``).

        The inverse simulation (eqs. 11-14) draws the head to each displacement field; of its residual on
        the rig's vertices, the part the volume could express (`Simulator.linear_fit`) is what the
        anatomy rejects (the rest is detail finer than the volume). Memoised per field's content, so the
        examples of a rising J are simulated once.
        """
        simulator = self.target if on_target else self.source
        result = np.empty_like(displacements)
        keys = [(on_target, content_digest(field)) for field in displacements]
        missing = []
        for row, key in enumerate(keys):
            found = self._rejected.get(key)
            if found is None:
                missing.append(row)
            else:
                result[row] = found
        for start in range(0, len(missing), BATCH):
            rows = missing[start : start + BATCH]
            result[rows] = self._reject(simulator, displacements[rows])
            for row in rows:
                self._rejected.put(keys[row], result[row].copy())
        return result

    def _reject(self, simulator: Simulator, displacements: np.ndarray) -> np.ndarray:
        """`rejected` of at most `BATCH` fields, not memoised."""
        volume = simulator.inverse(displacements, self.bones(simulator.head, displacements))
        return simulator.linear_fit(displacements - simulator.surface(volume))

    def source_terms(self, displacements: np.ndarray) -> SourceTerms:
        """`SourceTerms` of ``(B, N, 3)`` source expressions (turned like ``source_deltas``): ``invSim`` on
        ``H_S`` and ``fc(S_i, S, T)``."""
        ratios, scales, rotations = [], [], []
        rejected = np.empty_like(displacements)
        for start in range(0, len(displacements), BATCH):
            part = displacements[start : start + BATCH]
            rejected[start : start + BATCH] = self._reject(self.source, part)
            if self.settings.weights.characteristics != 0:
                neutral = self.source.head.neutral
                ratios.append(area_ratios(self.features, neutral, neutral + part))
                found = self.similarity(self.source, part, True)
                if found is not None:
                    scales.append(found[0])
                    rotations.append(found[1])
        return SourceTerms(
            displacements,
            rejected,
            np.concatenate(ratios) if ratios else None,
            np.concatenate(scales) if scales else None,
            np.concatenate(rotations) if rotations else None,
        )

    def source_shapes(self) -> SourceTerms:
        """The `SourceTerms` of the template's K shapes, computed once."""
        with self._lock:
            if self._shapes is None:
                self._shapes = self.source_terms(self.source_deltas)
            return self._shapes

    def anacon(
        self,
        displacements: np.ndarray,
        terms: SourceTerms | None = None,
        explained: Explained | None = None,
    ) -> np.ndarray:
        """``anacon(T_i^P + T_i^M hat, S_i, S, T)`` (eqs. 6, 19) of B target displacements.

        Parameters
        ----------
        displacements : (B, N, 3) array
            The retargeting to make plausible, ``T_i^P + T_i^M hat - T``.
        terms : SourceTerms, optional
            Of the B source expressions ``S_i``; by default the template's K shapes (`source_shapes`).
        explained : Explained, optional
            What the target examples determine of them; without, nothing (no examples).

        Returns
        -------
        (B, N, 3) displacements on the target neutral.
        """
        terms = self.source_shapes() if terms is None else terms
        rejected = terms.rejected if explained is None else terms.rejected - explained.source_rejected
        expected = self.transfer(True)(rejected)
        if explained is not None:
            expected = expected + explained.target_rejected
        result = np.empty_like(displacements)
        for start in range(0, len(displacements), BATCH):
            part = slice(start, start + BATCH)
            goal = displacements[part]
            volume = self.target.inverse(goal, self.bones(self.target.head, goal))
            surface = self.target.surface(volume)
            residual = goal - surface
            carried = residual - self.target.linear_fit(residual) + expected[part]
            neutral = self.target_neutral
            ratios, contour = self._asked(
                terms.part(part), None if explained is None else explained.part(part)
            )
            ratios, contour = self._for_volume(ratios, contour, carried, neutral + surface, neutral + goal)
            moved = self.target.forward(
                self.target._gradients(volume), volume[:, self.target.fixed], contour, ratios, volume
            )
            result[part] = self.target.surface(moved) + carried
        return result

    def _asked(
        self, terms: SourceTerms, explained: Explained | None
    ) -> tuple[np.ndarray | None, np.ndarray | None]:
        """The characteristics ``anacon`` asks of the whole result (eqs. 15-16), given what the examples
        explain: the explained part's eye areas and lip contour on the target, changed by what the source
        expression does beyond its explained part (area ratios to it, contour motion mapped by eq. 17's
        similarity). Without examples, ``fc(S_i, S, T)``."""
        ratios, motion = terms.ratios, terms.displacements
        target = self.target_neutral
        if explained is not None:
            triangles = self.features.area_triangles
            source = self.source_neutral
            motion = motion - explained.source
            if ratios is not None:
                ratios = (
                    ratios
                    * _area_ratio(source, source + explained.source, triangles)
                    * _area_ratio(target + explained.target, target, triangles)
                )
            target = target + explained.target
        if terms.scale is None:
            return ratios, None
        contour = self.target.contour
        return ratios, target[..., contour, :] + _mapped((terms.scale, terms.rotation), motion[:, contour])


def _mapped(found: tuple[np.ndarray, np.ndarray], motion: np.ndarray) -> np.ndarray:
    """``(B, L, 3)`` contour motions scaled and turned by eq. 17's ``(B,)`` scales and ``(B, 3, 3)``
    rotations."""
    scale, rotation = found
    return scale[:, None, None] * motion @ np.swapaxes(rotation, 1, 2)


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
