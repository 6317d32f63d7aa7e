"""Target example embedding (Wagner et al. 2024, sec. 3.5, eqs. 20-21).

Target examples without a matching source expression are first transferred to the source with
``adt`` (eq. 20), then reconstructed as a ridge combination of all source expressions (eqs. 1-3 with every
template shape as a blendshape); the combination is the example's embedding in the source domain (eq. 21),
free of the target's own details.
"""

from __future__ import annotations

import numpy as np


def ridge_weights(blendshapes: np.ndarray, goals: np.ndarray, lambda_reg: float, scale: float) -> np.ndarray:
    """``argmin_w |sum_k w_k B_k - G|^2 / scale^2 + lambda_reg |w|^2`` for every goal (eq. 2).

    Parameters
    ----------
    blendshapes : (K, N, 3) array
    goals : (J, N, 3) array
    lambda_reg : float
    scale : float
        Length unit of the data term (the template's bounding-box diagonal).

    Returns
    -------
    (J, K) array.
    """
    basis = blendshapes.reshape(len(blendshapes), -1) / scale
    gram = basis @ basis.T + lambda_reg * np.eye(len(blendshapes))
    return np.linalg.solve(gram, basis @ (goals.reshape(len(goals), -1) / scale).T).T


def embed_examples(
    anatomy: object, examples: np.ndarray, lambda_reg: float = 0.01, scale: float = 1.0
) -> np.ndarray:
    """Weights of the template's shapes that embed target examples in the source domain (eqs. 20-21).

    Parameters
    ----------
    anatomy : transfer._adt.Anatomy
        The template (aligned to the target) and the target's head.
    examples : (J, N, 3) array
        Target examples as displacements from the target neutral.
    lambda_reg : float
        Ridge weight of the reconstruction (Table 3: 0.01).
    scale : float
        Length unit of the data term.

    Returns
    -------
    (J, K) array ``w^adt``: ``S + sum_k w_jk A_k`` is the embedded example ``S_j`` (eq. 21).

    Notes
    -----
    One reverse ``adt`` per example (eq. 20) and one K x K ridge system for all of them.
    """
    on_source = anatomy.adt(examples, forward=False)
    return ridge_weights(anatomy.source_deltas, on_source, lambda_reg, scale)
