"""Li et al.'s per-triangle regularisation weights of example-based facial rigging (2010, sec. 3A): how
strongly each target shape is held to its deformation-transfer prior on each triangle.

Step A of ``ebfr`` (`transfer.ebfr`) weighs its fits with them, and so does the fit of one expression
(`transfer._expression_fit`) that it builds on.
"""

from __future__ import annotations

import numpy as np

from transfer._frames import TransferredEdges
from transfer._setup import TransferSetup


class Regularisation:
    """Per-triangle weights ``w_i = ((1 + |M_i^A|) / (kappa + |M_i^A|))^theta`` (Li et al. 2010, sec. 3A).

    Triangles that barely move in template shape i get the largest weight ``kappa^-theta``, so the
    target shape keeps the template's (lack of) motion there; strongly moving triangles may deviate.
    Weights are evaluated on demand for the triangles and shapes a fit needs (`block`).

    Parameters
    ----------
    setup : TransferSetup
        The aligned template and its constraint sets.
    kappa, theta : float
        Li et al. use ``kappa = 0.1`` and ``theta = 2``.
    motion_scale : {"peak", "absolute"}
        How ``|M_i^A|``, the Frobenius norm of shape i's edge displacements on a triangle, is measured.
        ``"peak"`` divides it by its largest value over the triangles of shape i, so the most active
        triangles of every shape get ``|M_i^A| = 1`` whatever the rig's units and resolution
        (Carrigan et al. 2020, sec. 5.2 aim for scale-free parameters). ``"absolute"`` follows Li et
        al. literally in the rig's units.

    Notes
    -----
    Weights lie between ``(2 / (kappa + 1))^theta`` and ``kappa^-theta`` for ``"peak"``; empty shapes get
    ``kappa^-theta`` everywhere. The peaks cost O(P) for the P (triangle, shape) pairs the shapes move
    (see `motion_peaks`).
    """

    def __init__(self, setup: TransferSetup, kappa: float, theta: float, motion_scale: str) -> None:
        if motion_scale not in ("peak", "absolute"):
            raise ValueError(f"motion_scale must be 'peak' or 'absolute', got {motion_scale!r}")
        self.prior = setup.prior
        self.kappa = kappa
        self.theta = theta
        n_shapes = setup.fixed.shape[0]
        self.scale = motion_peaks(setup) if motion_scale == "peak" else np.ones(n_shapes)

    def block(self, faces: np.ndarray, shapes: np.ndarray) -> np.ndarray:
        """``(F, S)`` weights of every shape in ``shapes`` on every triangle in ``faces``."""
        motion = edge_motion(self.prior, faces, shapes) / self.scale[shapes]
        return ((1.0 + motion) / (self.kappa + motion)) ** self.theta


def edge_motion(prior: TransferredEdges, faces: np.ndarray, shapes: np.ndarray) -> np.ndarray:
    """``(F, S)`` values of ``|M_i^A|``, the Frobenius norm of the edge displacements of every shape in
    ``shapes`` on every triangle in the sorted ``faces`` (zero where a shape moves no corner)."""
    motion = np.zeros((faces.size, shapes.size))
    for column, shape in enumerate(shapes):
        rows, found = prior.within(faces, shape)
        motion[rows, column] = prior.on_moving(shape)[1][found]
    return motion


def motion_peaks(setup: TransferSetup) -> np.ndarray:
    """Largest ``|M_i^A|`` over all triangles of each template shape; 1 where a shape does not move.

    Away from the triangles it moves (`TransferredEdges.moving`) a shape's edge motion is zero, so the
    peak is the largest of the motions `TransferredEdges.on_moving` keeps.

    Returns
    -------
    (K,) array of positive scales.
    """
    peaks = np.array(
        [setup.prior.on_moving(shape)[1].max(initial=0.0) for shape in range(setup.fixed.shape[0])]
    )
    return np.where(peaks > 0, peaks, 1.0)
