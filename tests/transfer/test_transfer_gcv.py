"""ebfr's balance beta chosen by generalized cross-validation (Golub, Heath & Wahba 1979; Li 2010, 3A)."""

from __future__ import annotations

import numpy as np
import pytest

import rigs
import transfer
from transfer import _gcv
from transfer._gcv import Spectra, choose_beta, gcv_scores, ridge_spectra


def _dense_gcv(regularisation, weights, residual, beta):
    """GCV from the explicit hat matrices ``W (W^T W + beta D_t)^-1 W^T`` of every triangle."""
    rss, trace = 0.0, 0.0
    for t in range(regularisation.shape[0]):
        hat = weights @ np.linalg.solve(weights.T @ weights + beta * np.diag(regularisation[t]), weights.T)
        rest = np.eye(weights.shape[0]) - hat
        rss += np.sum((rest @ residual[t].T) ** 2)
        trace += 6.0 * np.trace(rest)
    count = 6.0 * regularisation.shape[0] * weights.shape[0]
    return (rss / count) / (trace / count) ** 2


@pytest.mark.parametrize("shared", [False, True])
def test_pooled_gcv_matches_explicit_hat_matrices(shared):
    rng = np.random.default_rng(3)
    n_triangles, n_shapes, n_expressions = 4, 6, 3
    weights = np.zeros((n_expressions, n_shapes))
    weights[0, [0, 1]] = weights[1, [2]] = weights[2, [3, 4]] = 1.0
    if shared:
        weights[2, [0, 5]] = 1.0
    regularisation = rng.uniform(1.0, 100.0, (n_triangles, n_shapes))
    residual = rng.normal(size=(n_triangles, 6, n_expressions))
    spectra = ridge_spectra(regularisation, weights, residual)
    betas = np.array([1e-3, 0.1, 3.0])
    expected = [_dense_gcv(regularisation, weights, residual, beta) for beta in betas]
    np.testing.assert_allclose(gcv_scores(spectra, betas), expected, rtol=1e-9)


def _random_effects(noise: float, seed: int = 0) -> Spectra:
    """Residuals ``y ~ N(0, g + noise^2)``: the ridge prior with unit signal; the best beta is noise^2."""
    rng = np.random.default_rng(seed)
    eigenvalues = 10.0 ** rng.uniform(-3.0, 2.0, 20_000)
    energies = np.sum(rng.normal(size=(20_000, 6)) ** 2, axis=1) * (eigenvalues + noise**2)
    return Spectra(eigenvalues, energies)


def test_exact_data_choose_the_smallest_beta_and_noise_a_larger_one():
    assert choose_beta(_random_effects(0.0), 1e-4, 1.0).beta == pytest.approx(1e-4, rel=0.05)
    for noise in (0.1, 0.3):
        chosen = choose_beta(_random_effects(noise), 1e-4, 10.0).beta
        print(f"noise {noise}: beta {chosen:.3g}, ideal {noise**2:.3g}")
        assert noise**2 / 2 <= chosen <= 2 * noise**2


def test_gcv_choice_is_deterministic_and_empty_data_has_no_beta():
    first, second = choose_beta(_random_effects(0.2), 1e-4, 1.0), choose_beta(_random_effects(0.2), 1e-4, 1.0)
    assert first.beta == second.beta and np.array_equal(first.scores, second.scores)
    assert np.isnan(choose_beta(Spectra.join([]), 1e-4, 1.0).beta)


def test_pooled_spectra_score_the_grid_once_per_part(monkeypatch):
    """The first J expressions for a rising J: each part is scored on the grid once, for every pool."""
    parts = [_random_effects(noise, seed) for seed, noise in enumerate((0.1, 0.3, 0.05))]
    fresh = [Spectra.join([Spectra(p.eigenvalues, p.energies) for p in parts[:count]]) for count in (1, 2, 3)]
    plain = [choose_beta(pool, 1e-4, 1.0) for pool in fresh]  # every pool's parts scored anew
    scored: list[int] = []
    looped = _gcv._looped_sums

    def counted(spectra: Spectra, betas: np.ndarray) -> np.ndarray:
        scored.append(spectra.eigenvalues.size)
        return looped(spectra, betas)

    monkeypatch.setattr(_gcv, "_looped_sums", counted)
    kept = [choose_beta(Spectra.join(parts[:count]), 1e-4, 1.0) for count in (1, 2, 3)]
    assert scored == [part.eigenvalues.size for part in parts]
    pooled = Spectra(
        np.concatenate([p.eigenvalues for p in parts]), np.concatenate([p.energies for p in parts])
    )
    whole = choose_beta(pooled, 1e-4, 1.0)
    for first, second in zip(kept, plain, strict=True):
        assert first.beta == second.beta and np.array_equal(first.scores, second.scores)
    assert kept[-1].beta == pytest.approx(whole.beta, rel=1e-9)
    np.testing.assert_allclose(kept[-1].scores, whole.scores, rtol=1e-12)


@pytest.fixture(scope="module")
def isolated():
    """Every shape of a small generated rig scanned alone, on a warped character (J = K)."""
    template = rigs.generate("tiny")
    target = rigs.warp(template, "alien+character")
    weights = np.eye(template.n_shapes)
    return template, target, weights


def test_isolated_exact_examples_beat_dt_by_far(isolated):
    template, target, weights = isolated
    examples = transfer.training_expressions(target, weights)
    method = transfer.get("ebfr", beta="gcv")
    result = method(template, target.neutral, weights, examples)
    dt = transfer.get("dt")(template, target.neutral)
    ratio = transfer.rms(result, target.deltas) / transfer.rms(dt, target.deltas)
    fixed = transfer.rms(
        transfer.get("ebfr", beta=0.1)(template, target.neutral, weights, examples), target.deltas
    )
    beta = method.beta_used(template, target.neutral, weights, examples)
    baseline = transfer.rms(dt, target.deltas)
    print(f"ebfr/dt: gcv {ratio:.4f} (beta {beta:.3g}), fixed 0.1 {fixed / baseline:.4f}")
    assert ratio <= 0.35
    assert beta <= 1e-3
    again = transfer.get("ebfr", beta="gcv")(template, target.neutral, weights, examples)
    assert np.array_equal(result, again)


def test_noisy_examples_get_a_larger_beta(isolated):
    template, target, weights = isolated
    exact = transfer.training_expressions(target, weights)
    rng = np.random.default_rng(0)
    size = np.linalg.norm(target.deltas, axis=-1).max()
    noisy = exact + rng.normal(scale=0.05 * size, size=exact.shape)
    method = transfer.get("ebfr", beta="gcv")
    low = method.beta_used(template, target.neutral, weights, exact)
    high = method.beta_used(template, target.neutral, weights, noisy)
    print(f"beta: exact {low:.3g}, noisy {high:.3g}")
    assert high >= 30 * low


def test_gcv_prefixes_choose_per_j_and_match_direct_calls(isolated):
    template, target, weights = isolated
    examples = transfer.scan_expressions(target, weights, seed=1)
    method = transfer.get("ebfr", beta="gcv")
    first = method.prefixes(template, target.neutral, weights, examples)
    for count in (3, 7, 3, weights.shape[0]):
        direct = method(template, target.neutral, weights[:count], examples[:count])
        np.testing.assert_allclose(first(count), direct, rtol=0, atol=1e-12)


def test_gcv_is_the_default_and_a_fixed_beta_is_kept_as_given(isolated):
    template, target, weights = isolated
    examples = transfer.training_expressions(target, weights)
    default = transfer.get("ebfr")
    chosen = transfer.get("ebfr", beta="gcv").beta_used(template, target.neutral, weights, examples)
    assert default.beta == "gcv" and default.beta_used(template, target.neutral, weights, examples) == chosen
    assert np.array_equal(
        default(template, target.neutral, weights, examples),
        transfer.get("ebfr", beta="gcv")(template, target.neutral, weights, examples),
    )
    fixed = transfer.get("ebfr", beta=0.1)
    assert fixed.beta_used(template, target.neutral, weights, examples) == 0.1


def test_beta_curve_reports_rms_and_the_choice(isolated):
    template, target, weights = isolated
    examples = transfer.training_expressions(target, weights)
    curve = transfer.beta_curve(template, target, weights, examples, betas=[1e-3, 1e-2, 1e-1])
    assert np.all(np.diff(curve.rms) > 0) and np.all(np.diff(curve.scores) > 0)
    assert curve.chosen_rms <= curve.rms[0]


@pytest.mark.parametrize(
    ("params", "message"),
    [
        ({"beta": "auto"}, "beta must be a positive number or 'gcv'"),
        ({"beta_range": (1.0, 0.1)}, "low <= high"),
    ],
)
def test_bad_beta_settings_are_refused(params, message):
    with pytest.raises(ValueError, match=message):
        transfer.get("ebfr", **params)
