"""Scan-like training expressions: what a capture of the actor gives, not the linear sum of its blendshapes.

Carrigan et al. 2020 (sec. 5.1) evaluate packings with training expressions "copy-pasted" from the target's
ground-truth blendshapes (`transfer.training_expressions`): exactly the linear model every transfer method
assumes. A scanned actor is not that linear model. `scan_expressions` adds what a real capture has:

1. **Corrective terms.** Two shapes that act on the same or on neighbouring skin do not simply add: where
   their (slightly widened) supports meet, the skin bulges or flattens and the combined motion saturates.
   Each pair of shapes gets its own corrective field ``c_km h_km(v) (a_km n(v) + b_km u_km(v))``, with
   ``h_km = m_k m_m / (m_k + m_m)`` of the widened displacement lengths (zero wherever one shape does not
   reach), ``n`` the surface normal, ``u_km`` the direction of the pair's summed widened motion, and per-pair
   coefficients ``a_km`` in [-1, 1] (bulge or flatten) and ``b_km`` in [-1, -0.25] (saturation), scaled by
   the weights of both shapes (bilinear, like the second-order term of a combination model).
2. **Measurement noise** at scanner level: Gaussian per vertex, smoothed over a few rings of neighbours as
   registering a template to a scan smooths it, then rescaled to the requested standard deviation.
3. **Rigid head motion** between scans, small rotation and translation, which the pipeline removes by
   rigid alignment (weighted Kabsch) onto the neutral of the vertices the expression's own shapes move
   least, as a capture pipeline stabilises a scan on the skin the requested pose leaves still. That skin is
   not quite still (smoothing zones, noise, correctives), so some misalignment remains.

   The alignment weights are a continuous function of the motion (`alignment_weights`), not a hard
   selection of the least-moved vertices: a hard cut at the ``stable_share`` quantile lets a last-bit
   difference of the motion (another CPU's SIMD kernels), or the order in which a partition breaks a tie,
   swap vertices in or out of the set, which moved the transfer RMS by 1e-3 relative between machines.
   With a ramp, such a difference moves a weight by a last bit too.

The correctives belong to the actor (seeded by the shapes' names only, the same in every session); the
noise and head motion belong to the capture session (seeded by ``seed`` and the expression's index).
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING

import numpy as np

from registry import BoundedMemo
from transfer._digest import content_digest
from transfer._inputs import check_weights

if TYPE_CHECKING:
    import scipy.sparse as sp

    from rigs import Rig

#: Fewest vertices a rigid alignment can use.
_MIN_STABLE = 3
#: Scanners (widened shapes and neighbourhoods of one target) kept per process.
_SCANNER_CACHE_SIZE = 2
#: Bytes of scans a scanner keeps, so the packings of one rig that share a sequence's first expressions
#: capture them once.
_SCAN_BUDGET = 64 * 2**20
_scanners: BoundedMemo[_Scanner] = BoundedMemo(_SCANNER_CACHE_SIZE)


@dataclass(frozen=True)
class ScanModel:
    """How a scan of an expression differs from the linear sum of the target's blendshapes.

    Parameters
    ----------
    corrective : float >= 0, default 0.5
        Size of every pair's corrective field relative to ``h_km`` (0: none).
    reach : float >= 0, default 0.04
        Distance over which a shape's motion is widened, as a fraction of the bounding-box diagonal (1 cm
        on a 26 cm head), so shapes whose supports only come near each other also get a corrective; it is
        walked in rings of mesh neighbours of the mean edge length.
    noise : float >= 0, default 4e-4
        Standard deviation of the measurement noise per coordinate, as a fraction of the neutral's
        bounding-box diagonal (0.1 mm on a 26 cm head, the accuracy of a good photogrammetry rig).
    noise_smoothing : int >= 0, default 2
        Rings of neighbour averaging applied to the noise before it is rescaled.
    rotation : float >= 0, default 1.5
        Largest head rotation between scans, degrees (about a random axis through the neutral's centre).
    translation : float >= 0, default 0.004
        Largest head translation between scans, as a fraction of the bounding-box diagonal.
    stable_share : float in (0, 1], default 0.25
        Share of the vertices the rigid alignment rests on: those the expression's shapes move least
        (`alignment_weights` ramps their weights down towards the last of them).
    """

    corrective: float = 0.5
    reach: float = 0.04
    noise: float = 4e-4
    noise_smoothing: int = 2
    rotation: float = 1.5
    translation: float = 0.004
    stable_share: float = 0.25

    def __post_init__(self) -> None:
        for item in fields(self):
            value = getattr(self, item.name)
            if isinstance(value, bool) or not isinstance(value, int | float) or not np.isfinite(value):
                raise ValueError(f"ScanModel.{item.name} must be a finite number, got {value!r}")
            if value < 0:
                raise ValueError(f"ScanModel.{item.name} must be >= 0, got {value!r}")
        if int(self.noise_smoothing) != self.noise_smoothing:
            raise ValueError(f"ScanModel.noise_smoothing must be an integer, got {self.noise_smoothing!r}")
        if not 0.0 < self.stable_share <= 1.0:
            raise ValueError(f"ScanModel.stable_share must be in (0, 1], got {self.stable_share!r}")

    @property
    def ideal(self) -> bool:
        """Whether the model adds nothing (the scans are the linear sums)."""
        return self.corrective == self.noise == self.rotation == self.translation == 0.0


def scan_expressions(
    target: Rig, weights: object, *, seed: int = 0, model: ScanModel | None = None
) -> np.ndarray:
    """Scan-like training expressions of the target: correctives, scanner noise, head motion removed by
    rigid alignment (see the module documentation).

    Parameters
    ----------
    target : Rig
        The target rig B with its ground-truth blendshapes (the actor).
    weights : (J, K) array
        Blendshape weights of each expression (0/1 for a packing).
    seed : int >= 0
        Seed of the capture session: expression ``j`` draws its noise and head motion from
        ``default_rng([seed, j])``, so the first J scans are the same whatever the number of expressions.
    model : ScanModel, optional
        What the scans add; the default `ScanModel`. A model that adds nothing gives
        `transfer.training_expressions` up to rounding.

    Returns
    -------
    (J, N, 3) array of absolute vertex positions, rigidly aligned to the target neutral.

    Raises
    ------
    ValueError
        When ``target`` is not a rig, ``weights`` is not ``(J, K)`` for its K or holds non-finite values,
        or ``seed`` is not a non-negative integer.

    Notes
    -----
    O(K N R) once to widen the shapes over R rings, then per expression O(P N) for its P touching pairs and
    O(N noise_smoothing) for the noise.
    """
    from rigs import Rig

    if not isinstance(target, Rig):
        raise ValueError(f"target must be a rigs.Rig, got {type(target).__name__}")
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    model = ScanModel() if model is None else model
    if not isinstance(model, ScanModel):
        raise ValueError(f"model must be a transfer.ScanModel, got {type(model).__name__}")
    weight_array = check_weights(weights, target.n_shapes)
    if model.ideal or not len(weight_array):
        return target.neutral + np.tensordot(weight_array, target.deltas, axes=1)
    scanner = _scanner(target, model)
    return np.stack([scanner.scan(row, int(seed), j) for j, row in enumerate(weight_array)])


def _scanner(target: Rig, model: ScanModel) -> _Scanner:
    """The `_Scanner` of a target and model, memoised per process on the target's content
    (`content_digest` and the shape names), so the capture sessions of every packing of one rig widen its
    shapes once."""
    key = (content_digest(target.neutral, target.deltas, target.triangles), target.names, model)
    return _scanners.get_or_build(key, lambda: _Scanner(target, model))


class _Scanner:
    """What is shared by every scan of one target: widened shapes, touching pairs, normals, stable set."""

    def __init__(self, target: Rig, model: ScanModel) -> None:
        import scipy.sparse as sp

        self.model = model
        self.neutral = target.neutral
        self.deltas = target.deltas
        self.names = target.names
        self.diagonal = target.diagonal() or 1.0
        self.smoothing = _neighbour_average(target.n_vertices, target.triangles)
        deltas = target.deltas
        spread = deltas.transpose(1, 0, 2).reshape(target.n_vertices, -1)
        lengths = np.linalg.norm(deltas, axis=2).T
        for _ring in range(_rings(model.reach * self.diagonal, target.neutral, target.triangles)):
            spread = self.smoothing @ spread
            lengths = np.maximum(lengths, self.smoothing @ lengths)
        #: (K, N) widened displacement lengths and (K, N, 3) widened displacements.
        self.lengths = lengths.T
        self.spread = spread.reshape(target.n_vertices, target.n_shapes, 3).transpose(1, 0, 2)
        support = sp.csr_matrix(self.lengths > 0.0, dtype=np.float64)
        self.touching = (support @ support.T).toarray() > 0.0
        #: Vertices each widened shape reaches, sorted.
        self.support = np.split(support.indices, support.indptr[1:-1])
        self.normals = _vertex_normals(target.neutral, target.triangles)
        #: (K, N) displacement lengths, for the vertices each expression moves least.
        self.motion = np.linalg.norm(deltas, axis=2)
        self.n_stable = min(
            target.n_vertices, max(_MIN_STABLE, int(round(model.stable_share * target.n_vertices)))
        )
        self.centre = self.neutral.mean(axis=0)
        self._scans: BoundedMemo[np.ndarray] = BoundedMemo(_SCAN_BUDGET // max(self.neutral.nbytes, 1))

    def scan(self, weights: np.ndarray, seed: int, index: int) -> np.ndarray:
        """Scan ``index`` of the capture session ``seed``: `capture` with ``default_rng([seed, index])``,
        memoised (within `_SCAN_BUDGET`) on the weights, the seed and the index."""
        return self._scans.get_or_build(
            (weights.tobytes(), seed, index),
            lambda: _read_only(self.capture(weights, np.random.default_rng([seed, index]))),
        )

    def capture(self, weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """One scan: the linear expression of ``weights`` plus correctives and noise, moved rigidly, then
        aligned.

        Only the shapes with a nonzero weight are summed (an expression holds a few of the K shapes), by
        numpy's own loops: a BLAS product over all K shapes costs several times as much with two harness
        workers on two cores.
        """
        present = np.flatnonzero(weights)
        expression = self.neutral + np.einsum("k,knc->nc", weights[present], self.deltas[present])
        scan = expression + self.corrective(weights)
        if self.model.noise:
            scan = scan + self.noise(rng)
        if self.model.rotation or self.model.translation:
            scan = self.moved(scan, rng)
        moved = np.einsum("k,kn->n", np.abs(weights[present]), self.motion[present])
        return self.aligned(scan, alignment_weights(moved, self.n_stable))

    def corrective(self, weights: np.ndarray) -> np.ndarray:
        """Sum of the pair correctives of the shapes with nonzero weight."""
        total = np.zeros_like(self.neutral)
        if not self.model.corrective:
            return total
        present = np.flatnonzero(weights)
        for position, k in enumerate(present):
            for m in present[position + 1 :]:
                if not self.touching[k, m]:
                    continue
                a, b = _pair_coefficients(self.names[k], self.names[m])
                both = np.intersect1d(self.support[k], self.support[m], assume_unique=True)
                lk, lm = self.lengths[k, both], self.lengths[m, both]
                harmonic = lk * lm / (lk + lm)
                summed = self.spread[k, both] + self.spread[m, both]
                norm = np.sqrt(np.einsum("ij,ij->i", summed, summed))[:, None]
                along = np.divide(summed, norm, out=np.zeros_like(summed), where=norm > 0)
                size = self.model.corrective * weights[k] * weights[m] * harmonic
                total[both] += size[:, None] * (a * self.normals[both] + b * along)
        return total

    def noise(self, rng: np.random.Generator) -> np.ndarray:
        """Smoothed Gaussian noise with standard deviation ``noise * diagonal`` per coordinate."""
        field = rng.standard_normal(self.neutral.shape)
        for _ring in range(self.model.noise_smoothing):
            field = self.smoothing @ field
        deviation = field.std()
        if deviation > 0:
            field *= self.model.noise * self.diagonal / deviation
        return field

    def moved(self, scan: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """The scan turned about the neutral's centre and shifted, as the head moved between scans."""
        from scipy.spatial.transform import Rotation

        axis = rng.standard_normal(3)
        angle = np.radians(self.model.rotation) * rng.uniform()
        turn = Rotation.from_rotvec(angle * axis / np.linalg.norm(axis))
        shift = rng.standard_normal(3)
        shift *= self.model.translation * self.diagonal * rng.uniform() / np.linalg.norm(shift)
        return turn.apply(scan - self.centre) + self.centre + shift

    def aligned(self, scan: np.ndarray, weights: np.ndarray) -> np.ndarray:
        """Weighted Kabsch alignment of the scan onto the neutral (rotation, translation), ``weights`` per
        vertex as `alignment_weights` gives them."""
        from scipy.spatial.transform import Rotation

        used = np.flatnonzero(weights)
        share = weights[used] / weights[used].sum()
        reference, moving = self.neutral[used], scan[used]
        reference_centre, moving_centre = share @ reference, share @ moving
        turn, _ = Rotation.align_vectors(reference - reference_centre, moving - moving_centre, weights=share)
        return turn.apply(scan - moving_centre) + reference_centre


def alignment_weights(moved: np.ndarray, n_stable: int) -> np.ndarray:
    """Rigid-alignment weight of each vertex from how far the expression moves it.

    The ``n_stable`` least-moved vertices are the skin a capture pipeline stabilises on: with ``q`` the
    ``n_stable``-th smallest motion, a vertex weighs ``clip(2 (1 - moved / q), 0, 1)``, 1 up to ``q / 2``
    and falling linearly to 0 at ``q``. When ``q`` is 0 (more than ``n_stable`` vertices do not move at
    all), or no vertex moves less than ``q``, the vertices at ``q`` weigh 1.

    Parameters
    ----------
    moved : (N,) array of float >= 0
        Summed displacement length of the expression's shapes at each vertex.
    n_stable : int in [1, N]
        How many least-moved vertices the alignment rests on.

    Returns
    -------
    (N,) float array in [0, 1], with at least one positive entry.

    Notes
    -----
    The weights are continuous in ``moved``: unlike a hard selection of the ``n_stable`` smallest, a
    last-bit change of any motion, or a tie broken another way by a partition, changes the alignment by a
    last bit, so scans agree between machines whose numpy kernels round differently. O(N) time.
    """
    level = float(np.partition(moved, n_stable - 1)[n_stable - 1])
    weights = np.clip(2.0 * (1.0 - moved / level), 0.0, 1.0) if level > 0.0 else np.zeros(moved.shape)
    if not weights.any():  # no motion is below the level: those at it (every still vertex when it is 0)
        weights = (moved <= level).astype(np.float64)
    return weights


def _pair_coefficients(first: str, second: str) -> tuple[float, float]:
    """The actor's corrective coefficients ``(a, b)`` of a pair of shapes, whatever their order."""
    keys = sorted((zlib.crc32(first.encode()), zlib.crc32(second.encode())))
    rng = np.random.default_rng([*keys, zlib.crc32(b"corrective")])
    return float(rng.uniform(-1.0, 1.0)), float(rng.uniform(-1.0, -0.25))


def _rings(distance: float, neutral: np.ndarray, triangles: np.ndarray) -> int:
    """Rings of neighbours that walk about ``distance`` with the mesh's mean edge length."""
    if not distance or not len(triangles):
        return 0
    edges = neutral[np.roll(triangles, 1, axis=1)] - neutral[triangles]
    mean_edge = float(np.linalg.norm(edges, axis=2).mean())
    return max(1, int(np.ceil(distance / mean_edge))) if mean_edge > 0 else 0


def _neighbour_average(n_vertices: int, triangles: np.ndarray) -> sp.csr_matrix:
    """Row-stochastic averaging over each vertex and its mesh neighbours."""
    import scipy.sparse as sp

    rows = np.concatenate([triangles.ravel(), np.roll(triangles, 1, axis=1).ravel(), np.arange(n_vertices)])
    cols = np.concatenate([np.roll(triangles, 1, axis=1).ravel(), triangles.ravel(), np.arange(n_vertices)])
    adjacency = sp.csr_matrix((np.ones(rows.size), (rows, cols)), shape=(n_vertices, n_vertices))
    adjacency.data[:] = 1.0
    return sp.diags(1.0 / np.asarray(adjacency.sum(axis=1)).ravel()) @ adjacency


def _vertex_normals(neutral: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Area-weighted unit vertex normals (zero for a vertex in no triangle)."""
    a, b, c = (neutral[triangles[:, i]] for i in range(3))
    face = np.cross(b - a, c - a)
    normals = np.zeros_like(neutral)
    for corner in range(3):
        np.add.at(normals, triangles[:, corner], face)
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    return np.divide(normals, length, out=np.zeros_like(normals), where=length > 0)


def _read_only(array: np.ndarray) -> np.ndarray:
    """``array``, made read-only (a memoised scan is shared)."""
    array.flags.writeable = False
    return array
