"""Loading and saving rigs: one front door over every registered format (`rigs._formats`; the built-in ones
are listed in `rigs._builtin_formats`), told apart by the path (``format=`` overrides).

Every reader treats its files as untrusted (see :mod:`rigs._safe`): it reads only regular files inside the
rig's folder, sizes every array against what the files can hold before allocating it, and turns every
problem into a one-line `RigError` naming the file, the shape and what is wrong; what it leaves out or
doubts is named in a `RigWarning`.

Interchange formats are cleaned the same way after reading: displacements shorter than a relative
noise floor are zeroed (Carrigan et al. 2020, sec. 4.1, needs empty shapes to be truly empty), and the
rig's ``load_report`` (`rigs.LoadReport`) says what was found: the ``noise`` zeroed (floor and counts per
shape), the ``empty_shapes`` (kept, never dropped), the ``degenerate_triangles`` (reported, not fatal).
"""

from __future__ import annotations

import hashlib
import warnings
from dataclasses import replace
from inspect import Parameter, signature
from pathlib import Path
from typing import Any

import numpy as np

from rigs._format_table import plugin_origin
from rigs._formats import detect_format, format_for_writing, read_with, reader_of, rig_format, write_with
from rigs._inputs import RigInputs, record_folder, recording
from rigs._provenance import LoadReport, NoiseFloor
from rigs._rig import Rig, RigError, RigWarning, vector_lengths

DEFAULT_NOISE_FLOOR = 1e-6
#: Displacements shorter than this many rounding steps of the file's coordinates are noise: two
#: coordinates rounded to the same step differ by at most one step each, ``sqrt(3)`` steps in length.
ROUNDING_STEPS = 2.0


def load_with_inputs(path: str | Path, **options: Any) -> tuple[Rig, RigInputs]:
    """`load`, and what the read opened (`rigs.RigInputs`: every file's bytes hash and every folder
    listing searched, relative to the rig's folder): the rig's content, whose ``digest`` changes with
    any file the rig is made of.

    Parameters
    ----------
    path : path
        File or folder, as for `load`.
    **options
        Keyword arguments of `load`.

    Notes
    -----
    A rig of a plugin format (`rigs._format_table.plugin_origin`) is recorded as every file of its folder (the
    rig's folder, or the folder of its file) and that folder's listing: a plugin may open files by other
    means than `rigs._safe`, which records what the built-in readers open.
    """
    path = Path(path)
    with recording(path, None) if path.is_dir() else recording(path.parent, path) as inputs:
        rig = load(path, **options)
        given = options.get("format")
        kind = detect_format(path) if given is None else rig_format(given, path)
        if plugin_origin(kind):
            record_folder(path if path.is_dir() else path.parent, plugin_origin(kind))
    return rig, inputs


def load(
    path: str | Path,
    *,
    format: str | None = None,
    noise_floor: float | None = None,
    units: str | None = None,
    **options: Any,
) -> Rig:
    """Load a rig; the format follows from the path (see the module docstring).

    Parameters
    ----------
    path : path
        File or folder.
    format : str, optional
        A registered format's name (``"npz"``, ``"obj-folder"``, ``"gltf"``, ``"target"``, ``"usd"``, or a
        plugin's), overriding detection.
    noise_floor : float, optional
        Displacements shorter than ``noise_floor`` times the neutral's bounding-box diagonal are zeroed.
        Default ``1e-6`` for interchange formats; ``.npz`` files are loaded verbatim unless it is given.
    units : str, optional
        Length unit recorded in ``provenance.units``, overriding what the file says (OBJ says nothing;
        glTF says metres; USD its ``metersPerUnit``; ``.npz`` and manifests may say).
    **options
        Format options. ``obj-folder``: ``neutral`` (file name, default ``neutral.obj``).
        ``gltf``: ``mesh``, ``primitive``, ``weld``, ``weld_tolerance``, ``transform``
        (see :func:`rigs._gltf.load_gltf`). ``usd``: ``mesh`` (see :func:`rigs._usd.load_usd`).
        ``target``: ``crop_rings``; ``base`` (folders, archives);
        ``targets`` (member glob) and ``group_regions`` (OBJ group -> region name) for archives
        (see :mod:`rigs._target`).

    Returns
    -------
    Rig, with the ``source``, ``format`` and ``units`` (where known) in its ``provenance`` and the
    `rigs.LoadReport` of `with_report` in its ``load_report``.

    Raises
    ------
    RigError
        One line naming the file (and the shape, where there is one) and what is wrong with it, or the
        unknown option.

    Warns
    -----
    RigWarning
        For what the reader leaves out or doubts (see each reader).

    Examples
    --------
    >>> rig = load("face/")                       # doctest: +SKIP
    >>> rig = load("head.glb", mesh="Head", weld=True)  # doctest: +SKIP
    """
    path = Path(path)
    kind = detect_format(path) if format is None else rig_format(format, path)
    reader = reader_of(kind, path)
    accepted = [
        name
        for name, parameter in signature(reader).parameters.items()
        if parameter.kind is Parameter.KEYWORD_ONLY
    ]
    unknown = sorted(set(options) - set(accepted))
    if unknown:
        listed = ", ".join(accepted) or "none"
        raise RigError(f"{path}: unknown option {unknown[0]!r} for {kind.name} (accepted: {listed})")
    rig = read_with(kind, reader, path, options)
    if noise_floor is None:
        noise_floor = 0.0 if kind.verbatim else DEFAULT_NOISE_FLOOR
    if noise_floor < 0:
        raise RigError(f"{path}: noise_floor must be >= 0, got {noise_floor}")
    if units is not None:
        rig = replace(rig, provenance=replace(rig.provenance, units=units))
    return with_report(rig, noise_floor, origin=str(path))


def with_report(rig: Rig, noise_floor: float = DEFAULT_NOISE_FLOOR, *, origin: str = "") -> Rig:
    """``rig`` with sub-floor displacements zeroed and its ``load_report``.

    Parameters
    ----------
    rig : Rig
    noise_floor : float
        Relative to the neutral's bounding-box diagonal; 0 zeroes nothing. When ``provenance.decimal_step``
        says the file rounded its coordinates (OBJ written with fixed decimals), the floor is at least
        `ROUNDING_STEPS` such steps, since absolute positions differenced into deltas carry that error.
    origin : str
        The file or folder read, for messages.

    Returns
    -------
    Rig whose ``load_report`` (`rigs.LoadReport`) holds the ``noise`` (`rigs.NoiseFloor`: relative and
    absolute floor, rounding step, zeroed count per shape), the ``empty_shapes`` (names with no
    displacement left), the ``degenerate_triangles`` (count), the ``identical_shapes`` (groups of names
    whose displacements are equal at every vertex) and the ``case_twins`` (groups of names equal up to
    case).

    Warns
    -----
    RigWarning
        For a neutral that is no surface (no triangles, or every triangle of zero area: collapsed or
        colinear), which packs by its vertices but cannot be pictured or transferred; for a neutral out of
        line with its shapes (`common_offset`); and naming shapes that are identical, or whose names are
        equal up to case (one is likely a duplicate export; both are kept); and for a rig where most shapes
        move nearly every vertex (`moving_everywhere`: noise).

    Notes
    -----
    O(K N); five passes over the deltas.
    """

    step = rig.provenance.decimal_step
    floor = max(noise_floor * rig.diagonal(), ROUNDING_STEPS * step) if noise_floor > 0 else 0.0
    deltas = rig.deltas
    zeroed: dict[str, int] = {}
    if floor > 0 and rig.n_shapes:
        lengths = vector_lengths(deltas)
        noise = (lengths < floor) & (lengths > 0)
        counts = noise.sum(axis=1)
        if counts.any():
            deltas = np.where(noise[:, :, None], 0.0, deltas)
            zeroed = {rig.names[k]: int(counts[k]) for k in np.flatnonzero(counts)}
    empty = ~deltas.reshape(rig.n_shapes, -1).any(axis=1) if rig.n_shapes else np.zeros(0, dtype=bool)
    report = LoadReport(
        noise=NoiseFloor(float(noise_floor), float(floor), float(step), zeroed),
        empty_shapes=tuple(rig.names[k] for k in np.flatnonzero(empty)),
        degenerate_triangles=int(len(rig.degenerate_triangles())),
        identical_shapes=_identical_shapes(deltas, rig.names, empty),
        case_twins=_case_twins(rig.names),
    )
    label = origin or rig.provenance.label
    problem = _surface_problem(rig)
    if problem:
        warnings.warn(
            f"{label}: {problem}; it packs by its vertices, but cannot be pictured or transferred",
            RigWarning,
            stacklevel=3,
        )
    offset, largest = common_offset(deltas, max(floor, COMMON_OFFSET_SHARE * rig.diagonal()))
    if offset:
        warnings.warn(
            f"{label}: {offset} of its {rig.n_vertices} vertices are moved the same way by every one of its "
            f"{rig.n_shapes} blendshapes (by up to {largest:.3g}{_share_of_size(largest, rig)}): the neutral "
            "does not line up with the shapes (moved, or saved from another pose?), and every blendshape "
            "carries that offset",
            RigWarning,
            stacklevel=3,
        )
    everywhere = int(np.count_nonzero(moving_everywhere(deltas)))
    if everywhere >= max(NOISY_MIN_SHAPES, 0.5 * rig.n_shapes) and rig.n_vertices >= NOISY_MIN_VERTICES:
        floor_note = (
            f"the noise floor of {floor:.3g} left them"
            if floor > 0
            else "the file is read verbatim, with no noise floor"
        )
        warnings.warn(
            f"{label}: {everywhere} of its {rig.n_shapes} blendshapes move at least "
            f"{MOVING_EVERYWHERE:.0%} of its {rig.n_vertices} vertices ({floor_note}): a blendshape moves "
            "part of a face, so their displacements likely carry noise (a scan, a sculpt, export "
            "rounding), and every such shape overlaps every other one (sec. 4.1; rigs.load(..., "
            "noise_floor=F) zeroes displacements below F times the neutral's size: choose F above the noise)",
            RigWarning,
            stacklevel=3,
        )
    for group in report.identical_shapes:
        warnings.warn(
            f"{label}: shapes {', '.join(group)} are identical (the same displacement at every vertex)",
            RigWarning,
            stacklevel=3,
        )
    for group in report.case_twins:
        warnings.warn(
            f"{label}: shape names {', '.join(group)} differ only in case (a duplicate export?)",
            RigWarning,
            stacklevel=3,
        )
    return replace(rig, deltas=deltas, load_report=report)


#: Share of the vertices a blendshape moving "everywhere" moves (`moving_everywhere`), and the fewest such
#: shapes (and of the vertices) for `with_report` to warn of noise: a rig of a few whole-head shapes, or a
#: mesh of a few vertices, may move everything by design.
MOVING_EVERYWHERE = 0.99
NOISY_MIN_SHAPES = 3
NOISY_MIN_VERTICES = 100
#: Share of a shape's largest displacement that a vertex's must exceed to count as moved there.
MOVED_SHARE = 1e-4
#: Shapes whose displacement lengths `moving_everywhere` holds at once (bounds its memory on film rigs).
SHAPES_AT_ONCE = 64


def moving_everywhere(deltas: np.ndarray) -> np.ndarray:
    """(K,) bool: the blendshapes that move `MOVING_EVERYWHERE` of the vertices or more, a vertex counting as
    moved when its displacement exceeds `MOVED_SHARE` of the shape's largest (noise: a real blendshape moves
    part of a face, sec. 4.1; a sculpted falloff that never quite reaches zero does not count)."""
    n_shapes, n_vertices = deltas.shape[:2]
    everywhere = np.zeros(n_shapes, dtype=bool)
    if n_vertices == 0:
        return everywhere
    for start in range(0, n_shapes, SHAPES_AT_ONCE):
        lengths = vector_lengths(deltas[start : start + SHAPES_AT_ONCE])
        largest = lengths.max(axis=1, keepdims=True)
        moved = np.count_nonzero((lengths > MOVED_SHARE * largest) & (largest > 0), axis=1)
        everywhere[start : start + SHAPES_AT_ONCE] = moved >= MOVING_EVERYWHERE * n_vertices
    return everywhere


#: Fewest blendshapes for `common_offset` to judge: with fewer, all of them moving a vertex alike can be
#: the rig's own design (a rig of a few jaw shapes).
COMMON_OFFSET_MIN_SHAPES = 8
#: Least offset `common_offset` reports, as a share of the neutral's bounding-box diagonal (20 um on a
#: 20 cm head): below it, sculpted falloffs that never quite reach zero move a vertex alike in every shape.
COMMON_OFFSET_SHARE = 1e-4


def common_offset(deltas: np.ndarray, floor: float) -> tuple[int, float]:
    """The vertices that every blendshape moves the same way, and how far at least.

    In a rig each vertex is left still by most shapes, so the displacements of a vertex over the K shapes
    span a box holding the origin. A neutral moved, or saved from another pose than its shapes, adds its
    error to every delta: the box of each vertex it moved is shifted off the origin. A vertex whose box
    lies further than ``floor`` from the origin (every shape moving it further, each coordinate the same
    way; `with_report` passes the larger of the noise floor and `COMMON_OFFSET_SHARE` of the size) is
    counted, with the largest such distance, for rigs of at least `COMMON_OFFSET_MIN_SHAPES` shapes (the
    odds of chance noise doing it are 2^(1 - K) per coordinate).

    Returns
    -------
    count : int
    largest : float
        The largest distance of a counted vertex's box from the origin (0 when none is).
    """
    if deltas.shape[0] < COMMON_OFFSET_MIN_SHAPES:
        return 0, 0.0
    low, high = deltas.min(axis=0), deltas.max(axis=0)
    distance = vector_lengths(np.maximum(low, 0.0) + np.minimum(high, 0.0))  # (origin to the box)
    off = distance > floor
    return int(np.count_nonzero(off)), float(distance.max(initial=0.0))


def _share_of_size(length: float, rig: Rig) -> str:
    """``, 0.50% of the neutral's size`` (nothing for a neutral of no size)."""
    size = rig.diagonal()
    return f", {length / size:.2%} of the neutral's size" if size > 0 else ""


#: Every this many vertices, one is compared first when looking for identical shapes.
_SAMPLE_STRIDE = 61


def _surface_problem(rig: Rig) -> str:
    """Why the neutral is no surface (see `with_report`), or empty."""
    if rig.n_triangles == 0:
        return f"the neutral has no faces ({rig.n_vertices} points)"
    if len(rig.degenerate_triangles()) == rig.n_triangles:
        return (
            f"every one of the neutral's {rig.n_triangles} triangles has zero area (its vertices collapsed "
            "or in a line)"
        )
    return ""


def _identical_shapes(
    deltas: np.ndarray, names: tuple[str, ...], empty: np.ndarray
) -> tuple[tuple[str, ...], ...]:
    """Groups of two or more non-empty shapes whose displacements are bitwise equal, in rig order.

    Shapes are first told apart by a sample of their vertices (`_SAMPLE_STRIDE`), and only those alike
    there are hashed whole: a rig's shapes almost always differ in the sample, so a read does not hash
    every displacement.
    """
    candidates: dict[bytes, list[int]] = {}
    sample = np.ascontiguousarray(deltas[:, ::_SAMPLE_STRIDE])
    for k in np.flatnonzero(~empty):
        candidates.setdefault(sample[k].tobytes(), []).append(int(k))
    groups: dict[bytes, list[str]] = {}
    for members in (members for members in candidates.values() if len(members) > 1):
        for k in members:
            digest = hashlib.blake2b(np.ascontiguousarray(deltas[k]).data).digest()
            groups.setdefault(digest, []).append(names[k])
    return tuple(tuple(group) for group in groups.values() if len(group) > 1)


def _case_twins(names: tuple[str, ...]) -> tuple[tuple[str, ...], ...]:
    """Groups of two or more names equal up to case, in rig order."""
    groups: dict[str, list[str]] = {}
    for name in names:
        groups.setdefault(name.casefold(), []).append(name)
    return tuple(tuple(group) for group in groups.values() if len(group) > 1)


def save(rig: Rig, path: str | Path, *, format: str | None = None) -> Path:
    """Save a rig: ``*.npz`` as the native archive, ``*.usd``/``*.usda``/``*.usdc`` as UsdSkel blend shapes
    (:func:`rigs._usd.save_usd`), a folder (no suffix) as one OBJ per blendshape.

    Parameters
    ----------
    rig : Rig
    path : path
        ``name.npz``, ``name.usd[a|c]``, or a folder path without suffix (created; it must not hold other
        OBJ files).
    format : str, optional
        A registered format that writes (``"npz"``, ``"obj-folder"``, ``"usd"``, or a plugin's),
        overriding the choice by suffix.

    Returns
    -------
    The path written.

    Raises
    ------
    RigError
        When the format cannot be told from the path, or the writer refuses (see
        :func:`rigs._obj_folder.save_obj_folder`).
    """
    path = Path(path)
    kind = format_for_writing(path) if format is None else rig_format(format, path)
    return write_with(kind, rig, path)
