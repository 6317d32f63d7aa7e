"""HiGHS models from arrays through highspy: configured solvers, row-wise LPs and MILPs, start solutions.

Shared by the ``highs`` plugin (eq. 3), the colouring model of the fewest expressions (`solvers._colouring`),
MPS export (`solvers._mps`) and the LP relaxation of reduced-cost fixing (`solvers._fixing`). highspy must
be the HiGHS that OR-Tools bundles to share a process with it (docs/architecture.md; `solvers.highs`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import scipy.sparse as sp


def configured_highs(highspy, time_limit: float | None, seed: int, **options: float | bool | str):
    """A silent, single-threaded ``highspy.Highs`` with relative MIP gap 0, the seed, the time limit and
    ``options``.

    Raises
    ------
    RuntimeError
        When this HiGHS refuses an option (renamed or out of range in its version): a solve under
        settings other than the ones recorded would be a silently different benchmark.
    """
    highs = highspy.Highs()
    settings: dict[str, float | bool | str] = {
        "output_flag": False,
        "threads": 1,
        "random_seed": int(seed),
        "mip_rel_gap": 0.0,
        **({} if time_limit is None else {"time_limit": float(time_limit)}),
        **options,
    }
    for option, value in settings.items():
        if highs.setOptionValue(option, value) != highspy.HighsStatus.kOk:
            raise RuntimeError(f"HiGHS {highs.version()} refused the option {option}={value!r}")
    return highs


def highs_solution(highspy, values: np.ndarray):
    """``highspy.HighsSolution`` with the column values ``values`` (a start for ``Highs.setSolution``)."""
    solution = highspy.HighsSolution()
    solution.col_value = np.asarray(values, dtype=np.float64).tolist()
    solution.value_valid = True
    return solution


def highs_lp(
    highspy,
    matrix: sp.csr_matrix,
    row_lower: np.ndarray,
    row_upper: np.ndarray,
    cost: np.ndarray,
    col_lower: np.ndarray,
    col_upper: np.ndarray,
    *,
    maximise: bool = False,
    integral: bool = True,
):
    """``highspy.HighsLp`` of ``row_lower <= matrix @ x <= row_upper``, ``col_lower <= x <= col_upper``,
    every column integer (``integral``; else a linear program), optimising ``cost @ x`` (infinite row
    bounds become HiGHS's infinity): for a model with names (`solvers._mps`); `pass_model` hands a solver
    the same model faster."""
    n_rows, n_cols = matrix.shape
    lp = highspy.HighsLp()
    lp.num_col_, lp.num_row_ = n_cols, n_rows
    lp.sense_ = highspy.ObjSense.kMaximize if maximise else highspy.ObjSense.kMinimize
    lp.col_cost_ = np.asarray(cost, dtype=np.float64)
    lp.col_lower_, lp.col_upper_ = np.asarray(col_lower, np.float64), np.asarray(col_upper, np.float64)
    lp.row_lower_ = np.clip(np.asarray(row_lower, np.float64), -highspy.kHighsInf, highspy.kHighsInf)
    lp.row_upper_ = np.clip(np.asarray(row_upper, np.float64), -highspy.kHighsInf, highspy.kHighsInf)
    lp.a_matrix_.format_ = highspy.MatrixFormat.kRowwise
    lp.a_matrix_.num_col_, lp.a_matrix_.num_row_ = n_cols, n_rows
    lp.a_matrix_.start_ = matrix.indptr.astype(np.int32)
    lp.a_matrix_.index_ = matrix.indices.astype(np.int32)
    lp.a_matrix_.value_ = matrix.data.astype(np.float64)
    if integral:
        lp.integrality_ = [highspy.HighsVarType.kInteger] * n_cols
    return lp


def pass_model(
    highspy,
    highs,
    matrix: sp.csr_matrix,
    row_lower: np.ndarray,
    row_upper: np.ndarray,
    cost: np.ndarray,
    col_lower: np.ndarray,
    col_upper: np.ndarray,
    *,
    maximise: bool = False,
    integral: bool = True,
) -> None:
    """Hand ``highs`` the model of `highs_lp` through highspy's array form of ``passModel``: the arrays go
    over as they are, where a ``HighsLp`` filled attribute by attribute converts them (twenty times the
    time on the LPs of reduced-cost fixing).

    Raises
    ------
    ValueError
        When a bound or cost array does not have one value per row or column (HiGHS would read past it).
    RuntimeError
        When HiGHS refuses the model (e.g. a row naming a column twice).
    """
    n_rows, n_cols = matrix.shape
    for name, values, size in (
        ("row_lower", row_lower, n_rows), ("row_upper", row_upper, n_rows), ("cost", cost, n_cols),
        ("col_lower", col_lower, n_cols), ("col_upper", col_upper, n_cols),
    ):  # fmt: skip
        if np.shape(values) != (size,):
            raise ValueError(f"pass_model: {name} has shape {np.shape(values)}, not ({size},)")
    kind = highspy.HighsVarType.kInteger if integral else highspy.HighsVarType.kContinuous
    sense = highspy.ObjSense.kMaximize if maximise else highspy.ObjSense.kMinimize
    status = highs.passModel(
        n_cols, n_rows, int(matrix.nnz), int(highspy.MatrixFormat.kRowwise), int(sense), 0.0,
        np.asarray(cost, np.float64), np.asarray(col_lower, np.float64), np.asarray(col_upper, np.float64),
        np.clip(np.asarray(row_lower, np.float64), -highspy.kHighsInf, highspy.kHighsInf),
        np.clip(np.asarray(row_upper, np.float64), -highspy.kHighsInf, highspy.kHighsInf),
        matrix.indptr[:-1].astype(np.int32), matrix.indices.astype(np.int32), matrix.data.astype(np.float64),
        np.full(n_cols, int(kind), dtype=np.int32),
    )  # fmt: skip
    if status == highspy.HighsStatus.kError:
        raise RuntimeError(f"HiGHS {highs.version()} refused a model of {n_rows} rows and {n_cols} columns")
