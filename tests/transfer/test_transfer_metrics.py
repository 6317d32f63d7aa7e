"""RMS per vertex and its split into covered and uncovered shapes."""

from __future__ import annotations

import numpy as np
import pytest

import transfer


def test_rms_is_the_root_mean_square_vertex_distance():
    truth = np.zeros((2, 2, 3))
    estimate = np.zeros((2, 2, 3))
    estimate[0, 0] = [3.0, 4.0, 0.0]  # distance 5 at one of four vertices
    assert transfer.rms(estimate, truth) == pytest.approx(np.sqrt(25.0 / 4.0))
    assert transfer.rms(truth, truth) == 0.0
    assert transfer.rms(np.zeros((0, 5, 3)), np.zeros((0, 5, 3))) == 0.0


def test_rms_refuses_mismatched_or_non_finite_input():
    with pytest.raises(ValueError, match=r"estimate has shape \(2, 4, 3\) but truth has \(2, 5, 3\)"):
        transfer.rms(np.zeros((2, 4, 3)), np.zeros((2, 5, 3)))
    with pytest.raises(ValueError, match=r"truth must have shape \(K, N, 3\), got \(5, 3\)"):
        transfer.rms(np.zeros((5, 3)), np.zeros((5, 3)))
    estimate = np.zeros((1, 2, 3))
    estimate[0, 1, 2] = np.inf
    with pytest.raises(ValueError, match=r"estimate has a non-finite value at index \[0, 1, 2\]"):
        transfer.rms(estimate, np.zeros((1, 2, 3)))


def test_metrics_split_covered_and_uncovered_shapes():
    rng = np.random.default_rng(0)
    truth = rng.normal(size=(4, 10, 3))
    estimate = truth + rng.normal(size=(4, 10, 3)) * np.array([1.0, 2.0, 3.0, 4.0])[:, None, None]
    weights = np.array([[1.0, 0.0, 0.0, 1.0], [0.0, 0.0, 0.0, 1.0]])
    result = transfer.metrics(estimate, truth, weights)
    per_shape = [transfer.rms(estimate[[k]], truth[[k]]) for k in range(4)]
    np.testing.assert_allclose(result.per_shape, per_shape)
    assert result.covered.tolist() == [True, False, False, True]
    assert result.n_covered == 2
    assert result.rms == pytest.approx(transfer.rms(estimate, truth))
    assert result.rms_covered == pytest.approx(transfer.rms(estimate[[0, 3]], truth[[0, 3]]))
    assert result.rms_uncovered == pytest.approx(transfer.rms(estimate[[1, 2]], truth[[1, 2]]))
    assert result.worst(2).tolist() == list(np.argsort(per_shape)[::-1][:2])


def test_metrics_without_expressions_cover_nothing():
    truth = np.ones((3, 4, 3))
    result = transfer.metrics(truth * 1.5, truth)
    assert not result.covered.any()
    assert np.isnan(result.rms_covered)
    assert result.rms_uncovered == pytest.approx(result.rms)


def test_metrics_check_the_weights():
    truth = np.ones((3, 4, 3))
    with pytest.raises(ValueError, match=r"weights must have shape \(J, 3\) .*got \(2, 4\)"):
        transfer.metrics(truth, truth, np.zeros((2, 4)))
