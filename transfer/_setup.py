"""What deformation transfer and example-based rigging share for one template and target neutral.

Both methods rotate the template to face like the target, evaluate deformation-transfer edge targets
(Sumner & Popovic 2004; Li et al. 2010's prior ``M_k^{A*}``) and reconstruct vertices with each shape's
static vertices held. `transfer_setup` prepares that once per process for a rig pair, so a harness cell
evaluating ``dt`` and ``ebfr`` at many J values pays one prior and one factorisation per constraint set.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

from registry import BoundedMemo
from transfer._digest import content_digest
from transfer._frames import TransferredEdges, aligned_template
from transfer._reconstruct import FrameReconstruction, FreeBlock, constraint_groups

#: Set-ups kept per process (each holds a few (K, N, 3) arrays and sparse factors of one rig pair).
_CACHE_SIZE = 2
#: Entries of sparse factorisations a cached set-up keeps, so later solves skip the factorisations.
FACTOR_BUDGET = 20_000_000

_setups: BoundedMemo[TransferSetup] = BoundedMemo(_CACHE_SIZE)


class TransferSetup:
    """The aligned template, its deformation-transfer prior and the vertex solve on a target neutral.

    Parameters
    ----------
    template_neutral : (N, 3) array
    template_deltas : (K, N, 3) array
    triangles : (T, 3) int array
    target_neutral : (N, 3) array
    static_tolerance : float
        Vertices moving at most this fraction of a shape's largest displacement are held.
    align : bool
        Rotate the template to face like the target first (Kabsch).
    factor_budget : int
        Entries of factorised blocks kept between solves (see `FrameReconstruction`).

    Attributes
    ----------
    template_deltas : (K, N, 3) array
        The template's shapes, rotated to face like the target.
    prior : TransferredEdges
        Deformation-transfer edge targets ``M_k^{A*}`` of any triangle and shape.
    reconstruction : FrameReconstruction
    fixed : (K, N) bool array
        Vertices held in each shape.
    """

    def __init__(
        self,
        template_neutral: np.ndarray,
        template_deltas: np.ndarray,
        triangles: np.ndarray,
        target_neutral: np.ndarray,
        *,
        static_tolerance: float,
        align: bool,
        factor_budget: int,
    ) -> None:
        self.triangles = triangles
        neutral, self.template_deltas = aligned_template(
            template_neutral, template_deltas, target_neutral, align
        )
        self.prior = TransferredEdges(neutral, self.template_deltas, target_neutral, triangles)
        self.reconstruction = FrameReconstruction(target_neutral, triangles, factor_budget)
        self.fixed = self.reconstruction.constraints(self.template_deltas, static_tolerance)
        #: Index of each shape's constraint set in `groups`.
        self.group_of = np.empty(self.fixed.shape[0], dtype=np.intp)
        self.groups = constraint_groups(self.fixed)
        for index, members in enumerate(self.groups):
            self.group_of[members] = index
        self._faces: dict[int, np.ndarray] = {}
        self._transferred: np.ndarray | None = None
        self._derived: dict[Any, Any] = {}
        self._lock = threading.RLock()

    def faces(self, shapes: np.ndarray) -> np.ndarray:
        """Sorted triangles touching a free vertex of any of ``shapes``: all the edges their solves read."""
        parts = [self._group_faces(group) for group in np.unique(self.group_of[shapes])]
        return np.unique(np.concatenate(parts)) if parts else np.zeros(0, dtype=np.intp)

    def _group_faces(self, group: int) -> np.ndarray:
        found = self._faces.get(group)
        if found is None:
            found = self._faces[group] = self.reconstruction.faces(self.fixed[self.groups[group][0]])
        return found

    def solve(
        self, shapes: np.ndarray, faces: np.ndarray, edges: np.ndarray
    ) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """Free-vertex displacements of ``shapes`` from their edge targets on ``faces``.

        Parameters
        ----------
        shapes : (S,) int array
        faces : (F,) sorted int array
            At least `faces` of ``shapes``.
        edges : (F, 2, 3, S) array
            Edge targets of each shape on each of ``faces``.

        Yields
        ------
        members : int array
            Those of ``shapes`` sharing one constraint set.
        free : (V,) int array
            Their free vertices.
        values : (V, 3, len(members)) array
            Their displacements there; every other vertex keeps the template's displacement.
        """
        for members, columns, block, rows in self.blocks(shapes, faces):
            yield members, block.free, block.solve(edges[rows][..., columns], self._held(block, members))

    def blocks(
        self, shapes: np.ndarray, faces: np.ndarray
    ) -> Iterator[tuple[np.ndarray, np.ndarray, FreeBlock, np.ndarray]]:
        """Per constraint set of ``shapes`` with a free vertex: its members, their columns in ``shapes``,
        its factorised block and the rows of the block's triangles in the sorted ``faces``."""
        for group in np.unique(self.group_of[shapes]):
            columns = np.flatnonzero(self.group_of[shapes] == group)
            members = shapes[columns]
            block = self.block_of(members[0])
            if block is not None:
                yield members, columns, block, np.searchsorted(faces, block.faces)

    def block_of(self, shape: int) -> FreeBlock | None:
        """The factorised block of the constraint set of ``shape`` (`FrameReconstruction.block`)."""
        return self.reconstruction.block(self.fixed[shape])

    def transferred_on(self, members: np.ndarray, free: np.ndarray) -> np.ndarray:
        """``(V, 3, M)`` deformation transfer of shapes ``members`` at vertices ``free`` (`transferred`)."""
        return np.moveaxis(self.transferred[np.ix_(members, free)], 0, -1)

    def _held(self, block: FreeBlock, members: np.ndarray) -> np.ndarray:
        """``(H, 3, M)`` template displacements of the block's near held vertices in shapes ``members``."""
        return np.moveaxis(self.template_deltas[np.ix_(members, block.near)], 0, -1)

    @property
    def transferred(self) -> np.ndarray:
        """(K, N, 3) deformation transfer of every shape, read-only, computed on first use.

        Each constraint set reads the prior only on its own triangles (`FreeBlock.faces`).
        """
        with self._lock:
            if self._transferred is None:
                self._transferred = self.transfer_all()
                self._transferred.flags.writeable = False
        return self._transferred

    def transfer_all(self) -> np.ndarray:
        """(K, N, 3) deformation transfer of every shape, a new array (see `transferred`)."""
        result = np.array(self.template_deltas)
        for members in self.groups:
            block = self.block_of(members[0])
            if block is None:
                continue
            solved = block.solve(self.prior.block(block.faces, members), self._held(block, members))
            result[np.ix_(members, block.free)] = np.moveaxis(solved, -1, 0)
        return result

    def derived(self, key: Any, build: Callable[[], Any]) -> Any:
        """A value computed from this set-up by ``build``, kept with it under ``key``."""
        with self._lock:
            if key not in self._derived:
                self._derived[key] = build()
            return self._derived[key]


def transfer_setup(
    template: Any, target_neutral: np.ndarray, *, static_tolerance: float, align: bool
) -> TransferSetup:
    """The `TransferSetup` of a template rig and target neutral, memoised per process.

    The key is the content of the arrays (`content_digest`) and the parameters, so an equal rig built
    again shares the set-up; the last `_CACHE_SIZE` set-ups are kept with `FACTOR_BUDGET`
    entries of factorisations each.
    """
    digest = content_digest(template.neutral, template.deltas, template.triangles, target_neutral)
    return _setups.get_or_build(
        (digest, float(static_tolerance), bool(align)),
        lambda: TransferSetup(
            template.neutral,
            template.deltas,
            template.triangles,
            target_neutral,
            static_tolerance=static_tolerance,
            align=align,
            factor_budget=FACTOR_BUDGET,
        ),
    )
