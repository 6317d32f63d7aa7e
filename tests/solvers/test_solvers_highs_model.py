"""Models handed to HiGHS as arrays (`solvers._highs_model.pass_model`) against the same model built as a
``HighsLp`` (`highs_lp`), and the inputs HiGHS could not read safely."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from solvers._highs_model import configured_highs, highs_lp, pass_model

highspy = pytest.importorskip("highspy")


def _model(seed: int) -> tuple[sp.csr_matrix, np.ndarray]:
    rng = np.random.default_rng(seed)
    matrix = sp.random(30, 45, density=0.2, random_state=seed, format="csr")
    matrix.data[:] = 1.0
    return matrix, rng.random(45)


@pytest.mark.parametrize("integral", [False, True])
@pytest.mark.parametrize("maximise", [False, True])
@pytest.mark.parametrize("seed", [0, 1])
def test_the_arrays_give_the_model_of_a_highs_lp(seed, maximise, integral):
    matrix, weights = _model(seed)
    n_rows, n_cols = matrix.shape
    arguments = (
        matrix,
        np.full(n_rows, -np.inf),
        np.ones(n_rows),
        weights,
        np.zeros(n_cols),
        np.ones(n_cols),
    )
    passed, built = configured_highs(highspy, None, 0), configured_highs(highspy, None, 0)
    pass_model(highspy, passed, *arguments, maximise=maximise, integral=integral)
    built.passModel(highs_lp(highspy, *arguments, maximise=maximise, integral=integral))
    mine, theirs = passed.getLp(), built.getLp()
    for attribute in ("col_cost_", "col_lower_", "col_upper_", "row_lower_", "row_upper_"):
        assert np.array_equal(np.asarray(getattr(mine, attribute)), np.asarray(getattr(theirs, attribute)))
    kinds = [[int(kind) for kind in lp.integrality_] or [0] * n_cols for lp in (mine, theirs)]  # ([]: an LP)
    assert kinds[0] == kinds[1] == [int(integral)] * n_cols
    assert mine.sense_ == theirs.sense_
    for highs in (passed, built):
        highs.run()
    value = passed.getInfo().objective_function_value
    assert value == pytest.approx(built.getInfo().objective_function_value, abs=1e-9)
    assert (value > 0) == maximise  # (positive weights: the minimum takes nothing)


def test_an_array_of_another_length_is_refused_before_highs_reads_it():
    matrix, weights = _model(0)
    n_rows, n_cols = matrix.shape
    highs = configured_highs(highspy, None, 0)
    with pytest.raises(ValueError, match=r"cost has shape \(44,\), not \(45,\)"):
        pass_model(
            highspy, highs, matrix, np.full(n_rows, -np.inf), np.ones(n_rows), weights[:-1],
            np.zeros(n_cols), np.ones(n_cols),
        )  # fmt: skip


def test_a_model_highs_refuses_raises():
    matrix = sp.csr_matrix(
        (np.ones(3), np.array([0, 0, 1]), np.array([0, 2, 3])), shape=(2, 3)
    )  # (0, 0) twice
    highs = configured_highs(highspy, None, 0)
    with pytest.raises(RuntimeError, match="refused a model of 2 rows and 3 columns"):
        pass_model(
            highspy, highs, matrix, np.full(2, -np.inf), np.ones(2), np.ones(3), np.zeros(3), np.ones(3)
        )
