"""Symmetric blendshape pairs (sec. 4.4): mirror pairs (`packing._shape_symmetry`, eqs. 9-10), then motion
pairs (`packing._motion_symmetry`, eqs. 11-12), under the artist constraints."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp

from packing._binary import rig_masks
from packing._constraints import check_consistent, resolve_pairs
from packing._motion_symmetry import motion_symmetry, sketch_regions
from packing._params import PackingParams, params_from
from packing._shape_symmetry import axis_distances, reflection_normal, shape_symmetry
from registry import HarnessError
from rigs import Rig, compare_name_pairs, mirror_map, mirror_plane


@dataclass(frozen=True)
class SymmetryResult:
    """Detected pairs with their evidence.

    Attributes
    ----------
    shape_pairs : tuple of (int, int)
        Mirror pairs (eqs. 9-10), shape indices, lower index first, in order of increasing error.
    shape_errors : tuple of float
        ``max(eps_km, eps_mk)`` of each shape pair (eq. 9).
    motion_pairs : tuple of (int, int)
        Motion pairs (eqs. 11-12): first shape from the first region of its region pair.
    motion_cosines : tuple of float
        ``cos(phi_km)`` of each motion pair (eq. 12).
    self_symmetric : tuple of int
        Shapes symmetric to themselves, excluded from mirror pairs.
    overlapping : tuple of (int, int)
        Lowest-error mirror matches refused because their shapes share too many active vertices
        (sec. 4.4.1): shapes spread over both facial halves, never combined.
    artist_pairs : tuple of (int, int)
        The together pairs of the artist constraints, forced together like symmetry pairs.
    unmirrored : int
        Vertices without a mirror vertex (reported by the mirror map).
    notes : tuple of str
        What was skipped and why (e.g. a rig without the default sketch regions).
    """

    shape_pairs: tuple[tuple[int, int], ...] = ()
    shape_errors: tuple[float, ...] = ()
    motion_pairs: tuple[tuple[int, int], ...] = ()
    motion_cosines: tuple[float, ...] = ()
    self_symmetric: tuple[int, ...] = ()
    overlapping: tuple[tuple[int, int], ...] = ()
    artist_pairs: tuple[tuple[int, int], ...] = ()
    unmirrored: int = 0
    notes: tuple[str, ...] = ()

    @property
    def pairs(self) -> tuple[tuple[int, int], ...]:
        """Every pair forced together: mirror pairs, motion pairs, then the artist's together pairs."""
        return self.shape_pairs + self.motion_pairs + self.artist_pairs


def detect_pairs(
    rig: Rig,
    deltas_norms: np.ndarray | sp.spmatrix,
    masks: np.ndarray,
    empty: np.ndarray,
    params: PackingParams,
    together: list[tuple[int, int]] | None = None,
    apart: list[tuple[int, int]] | None = None,
    moved: np.ndarray | None = None,
) -> SymmetryResult:
    """Mirror pairs first, then motion pairs among the shapes left unpaired (sec. 4.4), under the artist
    constraints.

    Artist constraints override geometry: a detected pair that is an apart pair is dropped, a shape of a
    together pair joins no detected pair, and the together pairs are kept as `SymmetryResult.artist_pairs`.
    ``together`` and ``apart`` are shape index pairs (default: resolved from ``params``). ``moved``, the
    displacements of the active entries (`packing._binary.active_entries`), spares `shape_symmetry` reading
    them from the deltas (it is read, not changed).
    """
    if together is None or apart is None:
        together, apart = resolve_constraints(rig, params, empty)
    names = rig.names
    barred = {frozenset(pair) for pair in apart}
    in_together = np.zeros(rig.n_shapes, dtype=bool)
    in_together[[k for pair in together for k in pair]] = True
    eligible = ~empty & ~in_together
    notes: list[str] = []
    shape_pairs: list[tuple[int, int, float]] = []
    overlapping: list[tuple[int, int, float]] = []
    self_symmetric = np.zeros(rig.n_shapes, dtype=bool)
    unmirrored = 0
    if params.use_shape_symmetry:
        mirror = face_mirror(rig, masks, params.mirror_tol, notes)
        unmirrored = int(np.count_nonzero(mirror < 0))
        normal = reflection_normal(rig.neutral, mirror)
        if normal is None:
            notes.append("shape symmetry skipped: no vertex has a mirror vertex")
        else:
            shape_pairs, self_symmetric, overlapping = shape_symmetry(
                rig.deltas,
                deltas_norms,
                masks,
                mirror,
                normal,
                eligible,
                params.shape_tol,
                params.pair_overlap,
                axis_distances(rig.neutral, mirror, normal),
                rig.neutral,
                moved,
            )
        if unmirrored:
            notes.append(f"{unmirrored} of {rig.n_vertices} vertices have no mirror vertex")
        if overlapping:
            listed = ", ".join(f"{names[a]}+{names[b]} ({share:.0%})" for a, b, share in overlapping)
            notes.append(
                f"{len(overlapping)} mirror matches overlap on more than {params.pair_overlap:.0%} of their "
                f"active vertices away from the symmetry axis and are not paired (they spread over both "
                f"halves, sec. 4.4.1): {listed}"
            )
        shape_pairs = _drop_barred(shape_pairs, barred, names, notes)
        notes += _name_notes(shape_pairs, overlapping, self_symmetric, names, ~empty & ~in_together)
    motion_pairs: list[tuple[int, int, float]] = []
    if params.use_motion_symmetry:
        regions, region_pairs, note = sketch_regions(rig, params)
        if note:
            notes.append(note)
        paired = np.zeros(rig.n_shapes, dtype=bool)
        paired[[k for pair in shape_pairs for k in pair[:2]]] = True
        motion_pairs = motion_symmetry(
            rig.deltas,
            masks,
            regions,
            region_pairs,
            eligible & ~paired,
            params.motion_cos,
            params.motion_share,
        )
        motion_pairs = _drop_barred(motion_pairs, barred, names, notes)
    return SymmetryResult(
        shape_pairs=tuple((a, b) for a, b, _ in shape_pairs),
        shape_errors=tuple(error for *_, error in shape_pairs),
        motion_pairs=tuple((a, b) for a, b, _ in motion_pairs),
        motion_cosines=tuple(cosine for *_, cosine in motion_pairs),
        self_symmetric=tuple(int(k) for k in np.flatnonzero(self_symmetric)),
        overlapping=tuple((a, b) for a, b, _ in overlapping),
        artist_pairs=tuple(together),
        unmirrored=unmirrored,
        notes=tuple(notes),
    )


#: Share of the vertices the blendshapes move that may lack a mirror vertex before `face_mirror` fits the
#: symmetry plane on those vertices alone.
MIRROR_RETRY_SHARE = 0.05


def face_mirror(rig: Rig, masks: np.ndarray | sp.spmatrix, tol: float | None, notes: list[str]) -> np.ndarray:
    """The mirror map of eq. 9 (sec. 4.4.1): `rigs.mirror_map` of the neutral, or across the plane fitted on
    the vertices some blendshape moves when the whole mesh's plane leaves more than `MIRROR_RETRY_SHARE` of
    them without a mirror and that plane mirrors more of them (noted in ``notes``).

    A part that no shape moves and that has no mirror image (hair, a prop, a neck cut on one side) pulls
    the plane fitted on the whole mesh off the face; eq. 9 reads only the moved vertices, so their plane is
    the one that matters. A symmetric rig keeps the whole mesh's plane.
    """
    mirror = mirror_map(rig.neutral, tol=tol, triangles=rig.triangles)
    if sp.issparse(masks):
        moving = np.bincount(sp.csr_matrix(masks).indices, minlength=rig.n_vertices) > 0
    else:
        moving = np.asarray(masks, dtype=bool).any(axis=0)
    n_moving = int(np.count_nonzero(moving))
    missed = int(np.count_nonzero(mirror[moving] < 0))
    if n_moving < 3 or n_moving == rig.n_vertices or missed <= MIRROR_RETRY_SHARE * n_moving:
        return mirror
    triangles = rig.triangles
    inside = moving[triangles].all(axis=1) if len(triangles) else np.zeros(0, dtype=bool)
    renumbered = (np.cumsum(moving) - 1)[triangles[inside]] if inside.any() else None
    plane = mirror_plane(rig.neutral[moving], tol=tol, triangles=renumbered)
    retried = mirror_map(rig.neutral, plane=plane, tol=tol, triangles=rig.triangles)
    retried_missed = int(np.count_nonzero(retried[moving] < 0))
    if retried_missed >= missed:
        return mirror
    notes.append(
        f"symmetry plane fitted on the {n_moving} vertices the blendshapes move: the whole mesh's plane "
        f"left {missed} of them without a mirror vertex ({missed / n_moving:.0%}; a part no shape moves, "
        f"such as hair or a prop, pulled it), this one {retried_missed}"
    )
    return retried


def resolve_constraints(
    rig: Rig, params: PackingParams, empty: np.ndarray
) -> tuple[list[tuple[int, int]], list[tuple[int, int]]]:
    """The together and apart pairs of ``params`` as shape indices, checked against the rig.

    Raises
    ------
    ValueError
        For an unknown name (with close matches), a contradiction, or an empty shape in a together pair.
    """
    together = resolve_pairs(rig, params.together, "together")
    apart = resolve_pairs(rig, params.apart, "apart")
    check_consistent(rig, together, apart)
    for pair in together:
        for k in pair:
            if empty[k]:
                raise HarnessError(
                    f"together {','.join(rig.names[j] for j in pair)}: {rig.names[k]} is empty"
                )
    return together, apart


def _name_notes(
    shape_pairs: list[tuple[int, int, float]],
    overlapping: list[tuple[int, int, float]],
    self_symmetric: np.ndarray,
    names: tuple[str, ...],
    considered: np.ndarray,
) -> list[str]:
    """Cross-check of the mirror pairs against left/right names (`rigs.compare_name_pairs`): geometric pairs
    whose names say otherwise, and name twins geometry did not pair (refused as spread, self-symmetric, or
    not found), so that a user sees where the detector and the rig's naming disagree."""
    geometric = [(names[a], names[b]) for a, b, _ in shape_pairs]
    contradicting, missed = compare_name_pairs(geometric, names)
    spread = {frozenset((names[a], names[b])) for a, b, _ in overlapping}
    index = {name: k for k, name in enumerate(names)}
    missed = [
        pair
        for pair in missed
        if frozenset(pair) not in spread and all(considered[index[name]] for name in pair)
    ]
    notes = []
    if contradicting:
        listed = ", ".join(f"{a}+{b}" for a, b in contradicting)
        notes.append(f"mirror pairs whose left/right names are not twins (check them): {listed}")
    if missed:
        listed = ", ".join(
            f"{a}/{b}" + (" (self-symmetric)" if self_symmetric[[index[a], index[b]]].any() else "")
            for a, b in missed
        )
        notes.append(
            f"left/right-named twins that geometry did not pair (eqs. 9-10 found no match): {listed}"
        )
    return notes


def _drop_barred(
    pairs: list[tuple[int, int, float]], barred: set[frozenset[int]], names: tuple[str, ...], notes: list[str]
) -> list[tuple[int, int, float]]:
    """Detected pairs without the artist's apart pairs (each dropped one is noted)."""
    kept = [pair for pair in pairs if frozenset(pair[:2]) not in barred]
    for a, b, _ in (pair for pair in pairs if frozenset(pair[:2]) in barred):
        notes.append(f"{names[a]}+{names[b]} detected as a pair but kept apart by the artist constraints")
    return kept


def find_symmetry_pairs(
    rig: Rig, *, mu: float = 0.3, shape: bool = True, motion: bool = True, **params: Any
) -> list[tuple[str, str]]:
    """Symmetric blendshape pairs of a rig (Carrigan et al. 2020, sec. 4.4).

    Mirror pairs by shape symmetry (eqs. 9-10, over the vertex mirror map of the neutral), then
    motion pairs (eqs. 11-12, over the sketched region pairs) among the shapes not yet paired.
    Self-symmetric and empty shapes are never paired; each shape is in at most one pair.

    Parameters
    ----------
    rig : Rig
    mu : float in (0, 1]
        Threshold of the binary blendshapes (eq. 2).
    shape, motion : bool
        Switch each kind of symmetry on or off.
    **params
        Further `PackingParams`: ``shape_tol``, ``motion_cos``, ``motion_share``, ``region_pairs``,
        ``regions`` (mapping or JSON file), ``mirror_tol``, ``noise_floor``.

    Returns
    -------
    list of (str, str)
        Mirror pairs by increasing error, then motion pairs by increasing angle.

    Raises
    ------
    ValueError
        For parameters out of range or region names the rig (or regions file) does not have.
    """
    settings = params_from(mu=mu, shape_symmetry=shape, motion_symmetry=motion, **params)
    norms, empty, masks = rig_masks(rig, settings.mu, settings.noise_floor)
    result = detect_pairs(rig, norms, masks, empty, settings)
    return [(rig.names[a], rig.names[b]) for a, b in result.pairs]
