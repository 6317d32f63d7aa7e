"""The `Rig` value: a neutral mesh and its delta blendshapes (Carrigan et al. 2020, sec. 3)."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from registry import HarnessError
from rigs._provenance import LoadReport, Provenance, Surface, Truth


class RigError(HarnessError):
    """A rig, or a file that should hold one, is malformed.

    The message names the source (file or field), the shape if one is at fault, and what is wrong.
    """


class RigWarning(UserWarning):
    """A rig file loaded, but something in it was left out or looks doubtful.

    The message names the file, the shape if one is concerned, and what was left out or why it is doubtful.
    """


#: Largest magnitude of a coordinate or displacement: lengths, areas and normals of larger values overflow
#: float64 (a face mesh in any unit is far below).
LARGEST_COORDINATE = 1e150
#: NumPy kinds a coordinate or displacement may have: signed and unsigned integers and floats (no bool,
#: complex, string, object or date values, which a cast would silently turn into numbers).
_REAL_KINDS = "iuf"


#: Vectors per thread below which `vector_lengths` is not split (starting a thread costs about 0.1 ms).
THREADED_LENGTHS = 1 << 20


def vector_lengths(vectors: np.ndarray) -> np.ndarray:
    """Euclidean length of every 3-vector of a (..., 3) array, e.g. the (K, N) ``|dv_k^n|`` of a rig's
    deltas (Carrigan et al. 2020, eq. 2), the squares summed in one fixed order (`_lengths_into`).

    An array of more than `THREADED_LENGTHS` vectors is split along its first axis over the CPUs this
    process may use (NumPy releases the GIL in the sums); each length is computed exactly as on one thread.
    """
    vectors = np.asarray(vectors, dtype=np.float64)
    if vectors.ndim == 0 or vectors.shape[-1] != 3:
        raise ValueError(f"vector_lengths needs 3-vectors, an array of shape (..., 3); got {vectors.shape}")
    if vectors.ndim == 1:
        return np.sqrt((vectors[0] * vectors[0] + vectors[2] * vectors[2]) + vectors[1] * vectors[1])
    lengths = np.empty(vectors.shape[:-1])
    parts = min(_usable_cpus(), vectors.shape[0], -(-lengths.size // THREADED_LENGTHS))
    if parts <= 1:
        return _lengths_into(vectors, lengths)
    bounds = np.linspace(0, vectors.shape[0], parts + 1).astype(int).tolist()
    with ThreadPoolExecutor(parts) as pool:
        list(pool.map(lambda lo, hi: _lengths_into(vectors[lo:hi], lengths[lo:hi]), bounds[:-1], bounds[1:]))
    return lengths


def bounding_box(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper corners of the axis-aligned bounding box of (N, d) points, N >= 1.

    One reduction per coordinate: NumPy reduces an (N, 3) array along its first axis about twenty times
    slower than its three columns one by one.
    """
    columns = np.asarray(points).T
    return np.array([column.min() for column in columns]), np.array([column.max() for column in columns])


def _usable_cpus() -> int:
    """CPUs this process may run on (its affinity where the platform reports it)."""
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return max(1, os.cpu_count() or 1)


#: Vectors squared at a time by `_lengths_into` (its scratch is three floats a vector).
LENGTH_BLOCK = 1 << 16


def _lengths_into(vectors: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """Fill ``lengths`` (the shape of ``vectors`` without its last axis) with the vectors' lengths.

    The squares are summed as ``(x x + z z) + y y`` on every machine (``einsum``'s order depends on the
    vector width of the CPU: on 128-bit vectors it is this one), so that the lengths, and the masks of eq. 2
    drawn from them, are the same bit for bit wherever the rig is analysed, and `packing._binary`, which
    sums in this order too, agrees with them. A block of first-axis rows at a time keeps the scratch small.
    """
    rows = max(1, LENGTH_BLOCK // max(1, lengths[:1].size))
    for start in range(0, vectors.shape[0], rows):
        squares = np.square(vectors[start : start + rows])
        part = lengths[start : start + rows]
        np.add(squares[..., 0], squares[..., 2], out=part)
        part += squares[..., 1]
    return np.sqrt(lengths, out=lengths)


def _as_array(values: Any, what: str, source: str) -> np.ndarray:
    try:
        return np.asarray(values)
    except (TypeError, ValueError) as error:  # ragged nested lists
        raise RigError(f"{source}: {what} is not an array ({error})") from None


def _real_array(values: Any, what: str, source: str) -> np.ndarray:
    """``values`` as a float64 array, refusing non-numeric and complex data instead of casting it."""
    array = _as_array(values, what, source)
    if array.dtype.kind not in _REAL_KINDS:
        raise RigError(f"{source}: {what} must hold real numbers, got dtype {array.dtype}")
    return array.astype(np.float64, copy=False)


def _index_array(values: Any, what: str, source: str) -> np.ndarray:
    """``values`` as an int64 array; floats are accepted only when every value is a whole number."""
    array = _as_array(values, what, source)
    if array.dtype.kind == "f":
        if not np.all(np.isfinite(array)) or not np.all(np.mod(array, 1) == 0):
            raise RigError(f"{source}: {what} must hold integer vertex indices")
    elif array.dtype.kind not in "iu":
        raise RigError(f"{source}: {what} must hold integer vertex indices, got dtype {array.dtype}")
    return array.astype(np.int64)


def _frozen(array: np.ndarray) -> np.ndarray:
    array = np.ascontiguousarray(array)
    array.flags.writeable = False
    return array


def _check_displacements(deltas: np.ndarray, names: tuple[str, ...], source: str) -> None:
    """Raise `RigError` for the first blendshape with a non-finite displacement, else for the first with
    one beyond `LARGEST_COORDINATE`, naming the shape and the vertex.

    Notes
    -----
    Two reductions over the (K, N, 3) deltas (NaN propagates through both) and no temporary array of
    their size; only a shape found at fault is examined vertex by vertex.
    """
    if not deltas.size:
        return
    lowest, highest = deltas.min(axis=(1, 2)), deltas.max(axis=(1, 2))
    suspects = np.flatnonzero(~((lowest >= -LARGEST_COORDINATE) & (highest <= LARGEST_COORDINATE)))
    for k in suspects:
        bad = ~np.isfinite(deltas[k])
        if bad.any():
            vertex = int(np.argwhere(bad)[0, 0])
            raise RigError(
                f"{source}: blendshape {names[k]!r} has a non-finite displacement at vertex {vertex}"
            )
    if suspects.size:
        k = int(suspects[0])
        vertex = int(np.argwhere(np.abs(deltas[k]) > LARGEST_COORDINATE)[0, 0])
        raise RigError(
            f"{source}: blendshape {names[k]!r} has a displacement beyond {LARGEST_COORDINATE:g} at "
            f"vertex {vertex} (its lengths would overflow)"
        )


#: The record fields of a `Rig` and the type each must have (None allowed where the field is optional).
_RECORDS: tuple[tuple[str, type, bool], ...] = (
    ("provenance", Provenance, False),
    ("surface", Surface, True),
    ("load_report", LoadReport, True),
    ("truth", Truth, True),
)


def _check_records(rig: Rig, source: str) -> None:
    """Raise `RigError` for a record field of the wrong type (say, a plain dict), naming the field."""
    for name, kind, optional in _RECORDS:
        value = getattr(rig, name)
        if not (isinstance(value, kind) or (optional and value is None)):
            allowed = f"a {kind.__name__}" + (" or None" if optional else "")
            raise RigError(f"{source}: {name} must be {allowed}, got {type(value).__name__}")


def _landmarks(landmarks: Mapping[str, Any], source: str) -> dict[str, tuple[float, float, float]]:
    """Each landmark as a tuple of three finite floats, refusing any other point."""
    points: dict[str, tuple[float, float, float]] = {}
    for name, point in dict(landmarks).items():
        array = _real_array(point, f"landmark {name!r}", source)
        if array.shape != (3,):
            raise RigError(f"{source}: landmark {name!r} must have shape (3,), got {array.shape}")
        if not np.isfinite(array).all():
            raise RigError(f"{source}: landmark {name!r} has a non-finite coordinate")
        points[str(name)] = (float(array[0]), float(array[1]), float(array[2]))
    return points


def _has_surrogates(text: str) -> bool:
    """Whether ``text`` holds lone surrogates (the bytes of a file name that are not UTF-8, decoded with
    ``surrogateescape``), which no UTF-8 file, record or document can hold."""
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        return True
    return False


@dataclass(frozen=True, eq=False)
class Rig:
    """A blendshape rig: neutral mesh, K delta blendshapes, triangles and optional vertex regions.

    Delta blendshapes follow Carrigan et al. 2020, sec. 3: ``deltas[k] = v_k - v_0``.
    All arrays are stored read-only; use :func:`dataclasses.replace` to derive a new rig.

    Parameters
    ----------
    neutral : (N, 3) float array
        Vertex positions of the neutral expression ``v_0``.
    deltas : (K, N, 3) float array
        Displacement of each blendshape from the neutral.
    triangles : (T, 3) int array
        Triangle vertex indices (polygons are triangulated on load).
    names : sequence of K unique str
        Blendshape names, in the order of ``deltas``.
    regions : mapping str -> int array, optional
        Named vertex sets (e.g. ``upper_lip``), used for motion symmetry (sec. 4.4.2).
    faces : sequence of int arrays, optional
        The original polygons (quads, n-gons) as loaded, kept for OBJ export. ``None`` means the
        triangles are the faces.
    landmarks : mapping str -> (x, y, z), optional
        Named points of the neutral (``eye_L``, ``eye_R``, ``mouth``, ``nose`` of a generated rig), which
        warps locate their centres by; a warp moves them with the mesh.
    provenance : Provenance, optional
        Where the rig came from and how it was read or made (source, format, units, ...).
    surface : Surface, optional
        The mesh to draw besides the positions (texture coordinates, normals, materials), when the file
        held one.
    load_report : LoadReport, optional
        What cleaning the rig on load found (noise zeroed, empty and identical shapes, ...); None for a
        rig not cleaned by `rigs.load`.
    truth : Truth, optional
        The symmetry a generated rig was built with (its mirror and motion pairs).

    Raises
    ------
    RigError
        When shapes disagree, values are not finite, indices are out of range or names repeat.
        The message names the field and the bad value.
    """

    neutral: np.ndarray
    deltas: np.ndarray
    triangles: np.ndarray
    names: tuple[str, ...]
    regions: Mapping[str, np.ndarray] = field(default_factory=dict)
    faces: tuple[np.ndarray, ...] | None = None
    landmarks: Mapping[str, tuple[float, float, float]] = field(default_factory=dict)
    provenance: Provenance = field(default_factory=Provenance)
    surface: Surface | None = None
    load_report: LoadReport | None = None
    truth: Truth | None = None

    def __post_init__(self) -> None:
        source = self.provenance.label if isinstance(self.provenance, Provenance) else "rig"
        _check_records(self, source)
        neutral = _real_array(self.neutral, "neutral", source)
        if neutral.ndim != 2 or neutral.shape[1] != 3:
            raise RigError(f"{source}: neutral must have shape (N, 3), got {neutral.shape}")
        n_vertices = neutral.shape[0]
        if n_vertices == 0:
            raise RigError(f"{source}: neutral has no vertices")
        if not np.isfinite(neutral).all():
            bad = int(np.argwhere(~np.isfinite(neutral))[0, 0])
            raise RigError(f"{source}: neutral has a non-finite coordinate at vertex {bad}")
        if np.abs(neutral).max() > LARGEST_COORDINATE:
            bad = int(np.argwhere(np.abs(neutral) > LARGEST_COORDINATE)[0, 0])
            raise RigError(
                f"{source}: neutral has a coordinate beyond {LARGEST_COORDINATE:g} at vertex {bad} "
                "(its lengths would overflow)"
            )

        deltas = _real_array(self.deltas, "deltas", source)
        if deltas.ndim == 2 and deltas.shape == (0, 0):
            deltas = np.zeros((0, n_vertices, 3))
        if deltas.ndim != 3 or deltas.shape[1:] != (n_vertices, 3):
            raise RigError(
                f"{source}: deltas must have shape (K, {n_vertices}, 3) to match the neutral, "
                f"got {deltas.shape}"
            )

        names = tuple(str(name) for name in self.names)
        if len(names) != deltas.shape[0]:
            raise RigError(f"{source}: {len(names)} names for {deltas.shape[0]} blendshapes")
        seen: set[str] = set()
        for name in names:
            if not name:
                raise RigError(f"{source}: a blendshape has an empty name")
            if name in seen:
                raise RigError(f"{source}: duplicate blendshape name {name!r}")
            if _has_surrogates(name):
                raise RigError(
                    f"{source}: blendshape name {name!r} is not text (a file name whose bytes are not "
                    "UTF-8?); rename it"
                )
            seen.add(name)
        _check_displacements(deltas, names, source)

        triangles = _index_array(self.triangles, "triangles", source)
        if triangles.size == 0:
            triangles = triangles.reshape(0, 3)
        if triangles.ndim != 2 or triangles.shape[1] != 3:
            raise RigError(f"{source}: triangles must have shape (T, 3), got {triangles.shape}")
        if triangles.size and (triangles.min() < 0 or triangles.max() >= n_vertices):
            bad = int(np.flatnonzero((triangles < 0).any(axis=1) | (triangles >= n_vertices).any(axis=1))[0])
            raise RigError(
                f"{source}: triangle {bad} {triangles[bad].tolist()} indexes outside 0..{n_vertices - 1}"
            )

        regions: dict[str, np.ndarray] = {}
        for region_name, indices in dict(self.regions).items():
            if not str(region_name):
                raise RigError(f"{source}: a region has an empty name")
            indices = _as_array(indices, f"region {region_name!r}", source)
            if indices.ndim > 1:
                raise RigError(
                    f"{source}: region {region_name!r} must be a flat list of vertex indices, got an array "
                    f"of shape {indices.shape}"
                )
            if indices.dtype == bool:
                if indices.shape != (n_vertices,):
                    raise RigError(f"{source}: region {region_name!r} mask has shape {indices.shape}")
                indices = np.flatnonzero(indices)
            indices = np.unique(_index_array(indices, f"region {region_name!r}", source).ravel())
            if indices.size and (indices[0] < 0 or indices[-1] >= n_vertices):
                raise RigError(f"{source}: region {region_name!r} indexes outside 0..{n_vertices - 1}")
            regions[str(region_name)] = _frozen(indices)

        faces = None
        if self.faces is not None:
            faces = tuple(_frozen(np.asarray(face, dtype=np.int64).ravel()) for face in self.faces)
            if faces:
                sizes = np.fromiter((face.size for face in faces), dtype=np.int64, count=len(faces))
                flat = np.concatenate(faces)
                outside = np.add.reduceat((flat < 0) | (flat >= n_vertices), np.cumsum(sizes) - sizes)
                bad = np.flatnonzero((sizes < 3) | (outside > 0))
                if bad.size:
                    index = int(bad[0])
                    polygon = faces[index].tolist()
                    raise RigError(f"{source}: face {index} {polygon} is not a polygon of this mesh")

        object.__setattr__(self, "neutral", _frozen(neutral))
        object.__setattr__(self, "deltas", _frozen(deltas))
        object.__setattr__(self, "triangles", _frozen(triangles))
        object.__setattr__(self, "names", names)
        object.__setattr__(self, "regions", regions)
        object.__setattr__(self, "faces", faces)
        object.__setattr__(self, "landmarks", _landmarks(self.landmarks, source))

    # -- sizes -------------------------------------------------------------------------------------------
    @property
    def n_vertices(self) -> int:
        """N, the number of vertices."""
        return int(self.neutral.shape[0])

    @property
    def n_shapes(self) -> int:
        """K, the number of blendshapes."""
        return int(self.deltas.shape[0])

    @property
    def n_triangles(self) -> int:
        """T, the number of triangles."""
        return int(self.triangles.shape[0])

    # -- look-ups ----------------------------------------------------------------------------------------
    def index(self, name: str) -> int:
        """Position of blendshape ``name``; raises `RigError` listing near names when absent."""
        try:
            return self.names.index(name)
        except ValueError:
            import difflib

            close = difflib.get_close_matches(name, self.names, n=3)
            hint = f" (did you mean {', '.join(close)}?)" if close else ""
            raise RigError(f"{self.provenance.label}: no blendshape named {name!r}{hint}") from None

    def indices(self, names: Sequence[str]) -> np.ndarray:
        """Positions of several blendshapes, in the given order."""
        return np.array([self.index(name) for name in names], dtype=np.int64)

    def shape(self, name: str) -> np.ndarray:
        """Absolute vertex positions of blendshape ``name`` (neutral + delta)."""
        return self.neutral + self.deltas[self.index(name)]

    def degenerate_triangles(self, rel_tol: float = 1e-12) -> np.ndarray:
        """Indices of zero-area triangles of the neutral (reported, not fatal)."""
        if self.n_triangles == 0:
            return np.zeros(0, dtype=np.int64)
        a, b, c = (self.neutral[self.triangles[:, i]] for i in range(3))
        doubled_area = np.linalg.norm(np.cross(b - a, c - a), axis=1)
        low, high = self.bounding_box()
        scale = float((high - low).max()) or 1.0
        return np.flatnonzero(doubled_area <= rel_tol * scale * scale)

    def bounding_box(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper corners of the neutral's axis-aligned bounding box."""
        return bounding_box(self.neutral)

    def diagonal(self) -> float:
        """Length of the neutral's bounding-box diagonal (the rig's scale)."""
        low, high = self.bounding_box()
        return float(np.linalg.norm(high - low))

    def subset(self, names: Sequence[str]) -> Rig:
        """A rig with only the named blendshapes, in the given order."""
        from dataclasses import replace

        order = self.indices(names)
        return replace(self, deltas=self.deltas[order], names=tuple(self.names[i] for i in order))

    def __repr__(self) -> str:
        return (
            f"Rig(N={self.n_vertices}, K={self.n_shapes}, T={self.n_triangles}, "
            f"regions={sorted(self.regions)}, source={self.provenance.source or '?'!r})"
        )
