"""Step A of example-based rigging for one expression of a packing, in closed form in ``beta``.

In a packing no shape is in two expressions, so Li et al.'s per-triangle fit (2010, sec. 3A) splits into one
problem per expression (`transfer.ebfr.GradientSpaceRigging`), each with a single training example. With
weights ``w`` on the expression's S shapes, the Woodbury form of `transfer.ebfr.fit_edge_frames` then has
``J = 1``: ``G_t = g_t = sum_i w_i^2 / w_ti`` is a number per triangle and the update of shape i is

    Delta_ti = (w_i / w_ti) y_t / (beta + g_t),   y_t = R_t - sum_i w_i P_ti,

with ``P`` the deformation-transfer prior, ``R_t`` the example's edges and ``w_ti`` the regularisation
weights. The vertex solve is linear in the edge targets and deformation transfer is its solve of ``P``,
so the fitted shapes are deformation transfer plus the response to ``Delta`` alone
(`transfer._reconstruct.FreeBlock.respond`). Everything but the factor ``1 / (beta + g_t)`` is kept:
what depends on the shapes and weights only (`ExpressionSystem`: the prior's prediction, ``g_t``,
``w_i / w_ti``, the constraint sets and their deformation transfer) once per weights, what depends on the
example (`ExpressionFit`: ``y_t``) once per example, so the GCV choice of ``beta`` (`transfer._gcv`) and
the fits at every ``beta`` it asks for evaluate no prior, regularisation or edges again.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from transfer._frames import edge_vectors
from transfer._gcv import Spectra

if TYPE_CHECKING:
    from transfer._regularisation import Regularisation
    from transfer._setup import TransferSetup

#: Fitted shapes of one expression: (shapes, free vertices, (V, 3, len(shapes)) displacements) per
#: constraint set, as `transfer._setup.TransferSetup.solve` yields them.
Fitted = list[tuple[np.ndarray, np.ndarray, np.ndarray]]


@dataclass(frozen=True)
class ConstraintPart:
    """The shapes of an expression that share one set of held vertices, and where their solve reads.

    Attributes
    ----------
    members : (M,) int array
        The shapes.
    rows : (B,) int array
        The places of the block's triangles (`transfer._reconstruct.FreeBlock.faces`) among the
        expression's triangles.
    free : (V,) int array
        The block's free vertices.
    transferred : (V, 3, M) array
        Deformation transfer of the members there.
    eigenvalues : (B,) array
        ``g_t`` on the block's triangles.
    gains : (B, M) array
        ``w_i / w_ti`` of the members there.
    """

    members: np.ndarray
    rows: np.ndarray
    free: np.ndarray
    transferred: np.ndarray
    eigenvalues: np.ndarray
    gains: np.ndarray


@dataclass(frozen=True)
class ExpressionSystem:
    """What step A needs of one expression's shapes and weights, for any example and ``beta``.

    Attributes
    ----------
    shapes : (S,) int array
        Its shapes.
    faces : (F,) int array
        The sorted triangles touching a free vertex of any of them (`TransferSetup.faces`).
    predicted : (F, 6, 1) array
        The prior's prediction of the example's edges, ``sum_i w_i P_ti``.
    eigenvalues : (F,) array
        ``g_t = sum_i w_i^2 / w_ti``.
    parts : tuple of ConstraintPart
        The shapes by constraint set with a free vertex, with ``g_t`` and ``w_i / w_ti`` on the
        triangles their solve reads.

    Notes
    -----
    Building costs O(F S) for the prior and the regularisation weights on the F triangles, and the
    deformation transfer of the shapes is read from the set-up.
    """

    shapes: np.ndarray
    faces: np.ndarray
    predicted: np.ndarray
    eigenvalues: np.ndarray
    parts: tuple[ConstraintPart, ...]

    @classmethod
    def build(cls, setup: TransferSetup, regularisation: Regularisation, row: np.ndarray) -> ExpressionSystem:
        """The system of the expression with ``(K,)`` weights ``row``, at least one nonzero."""
        shapes = np.flatnonzero(row)
        weights = row[None, shapes]
        faces = setup.faces(shapes)
        prior = setup.prior.block(faces, shapes).reshape(faces.size, 6, shapes.size)
        damping = regularisation.block(faces, shapes)
        eigenvalues = ((1.0 / damping) @ (weights**2).T).ravel()
        gains = weights / damping
        parts = tuple(
            ConstraintPart(
                members,
                rows,
                block.free,
                setup.transferred_on(members, block.free),
                eigenvalues[rows],
                gains[np.ix_(rows, columns)],
            )
            for members, columns, block, rows in setup.blocks(shapes, faces)
        )
        return cls(shapes, faces, prior @ weights.T, eigenvalues, parts)

    def fit(self, setup: TransferSetup, offsets: np.ndarray) -> ExpressionFit:
        """The expression with the example whose ``(N, 3, 1)`` ``offsets`` from the target neutral are
        given."""
        observed = edge_vectors(offsets, setup.triangles[self.faces]).reshape(self.faces.size, 6, 1)
        residual = observed - self.predicted
        return ExpressionFit(self, residual, Spectra(self.eigenvalues, np.sum(residual**2, axis=1).ravel()))


@dataclass(frozen=True)
class ExpressionFit:
    """One expression of a packing with its example, at any ``beta``.

    Attributes
    ----------
    system : ExpressionSystem
    residual : (F, 6, 1) array
        ``y_t``, the example's edges minus the prior's prediction of them.
    spectra : Spectra
        The GCV data of the F one-example systems: ``g_t`` and ``|y_t|^2`` (`transfer._gcv`).
    """

    system: ExpressionSystem
    residual: np.ndarray
    spectra: Spectra

    def fitted(self, setup: TransferSetup, beta: float) -> Fitted:
        """Free-vertex displacements of the expression's shapes fitted with balance ``beta``.

        O(F S) plus one sparse product and triangular solve per constraint set.
        """
        result = []
        for part in self.system.parts:
            scale = part.gains / (beta + part.eigenvalues)[:, None]  # (B, M)
            edges = (self.residual[part.rows] * scale[:, None, :]).reshape(part.rows.size, 2, 3, -1)
            values = part.transferred + setup.block_of(part.members[0]).respond(edges)
            result.append((part.members, part.free, values))
        return result
