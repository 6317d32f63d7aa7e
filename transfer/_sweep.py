"""Example-based rigging's error against ground truth over a range of ``beta`` (evaluation only)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from transfer._gcv import BetaChoice, gcv_scores
from transfer._metrics import rms


@dataclass(frozen=True)
class BetaCurve:
    """RMS error and GCV score of example-based rigging at several ``beta`` (`beta_curve`).

    Attributes
    ----------
    betas : (B,) array
    rms : (B,) array
        RMS error against the target's true blendshapes at each ``beta``.
    scores : (B,) array
        GCV score at each ``beta`` (`transfer._gcv.gcv_scores`); it uses no ground truth.
    choice : BetaChoice
        What ``beta="gcv"`` picks for the same inputs.
    chosen_rms : float
        RMS error at the chosen ``beta`` (NaN without training expressions).
    """

    betas: np.ndarray
    rms: np.ndarray
    scores: np.ndarray
    choice: BetaChoice
    chosen_rms: float


def beta_curve(
    template: Any,
    target: Any,
    weights: np.ndarray,
    examples: np.ndarray,
    *,
    betas: np.ndarray | None = None,
    **params: Any,
) -> BetaCurve:
    """Where example-based rigging starts to over- or under-fit, and what GCV picks (Li et al. 2010, 3A).

    Parameters
    ----------
    template : Rig
        Template rig A.
    target : Rig
        Target rig B with its true blendshapes (ground truth, used only for the RMS column).
    weights : (J, K) array
    examples : (J, N, 3) array
        Training expressions (`training_expressions` or `scan_expressions`).
    betas : (B,) array, optional
        Default: the GCV grid over ``beta_range``.
    **params
        Other `transfer.ebfr.ExampleBasedRigging` parameters (``beta_range``, ``kappa``, ...).

    Returns
    -------
    BetaCurve

    Notes
    -----
    One fit per ``beta`` (each reusing the shared set-up) plus the GCV choice; the scores cost no fit.
    """
    from transfer.ebfr import ExampleBasedRigging  # importing transfer must not load scipy

    method = ExampleBasedRigging(beta="gcv", **params)
    inputs = method.checked(template, target.neutral, weights, examples)
    rigging = method.rigging(inputs)
    choice = rigging.choose_beta(inputs.weights, *method.beta_range)
    grid = choice.grid if betas is None else np.asarray(betas, dtype=float)
    errors = np.array([rms(rigging.blendshapes(inputs.weights, float(beta)), target.deltas) for beta in grid])
    scores = gcv_scores(rigging.spectra(inputs.weights), grid)
    chosen = np.nan
    if np.isfinite(choice.beta):
        chosen = rms(rigging.blendshapes(inputs.weights, choice.beta), target.deltas)
    return BetaCurve(grid, errors, scores, choice, float(chosen))
