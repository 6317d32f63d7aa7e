"""The presolved model of eq. 3 as an MPS file, and MIPLIB ``.solu`` lines, for tools outside the harness.

`write_mps` hands a `CliqueModel` (what every exact backend builds: ``max w.x`` over the clique rows and the
cap row, x binary) to HiGHS as arrays and lets HiGHS's own MPS writer write it, so the file is exactly the
model the backends solve. The file *minimises the negated objective* ``-w.x``: MPS has no standard way to
say "maximise" (the ``OBJSENSE`` section is an extension, and CBC 2.10, the CBC that PuLP bundles, ignores it
and minimises ``w.x``, answering 0), while every reader minimises by default. It is **free MPS**: column
names are the items' labels, up to 255 characters (``eyeBlink_L+eyeBlink_R``), which a fixed-format reader
would cut at 8; a comment at its top says both. HiGHS writes the coefficients with 15 significant digits;
`write_mps` reads the file back with HiGHS's parser and returns them as written, so that a value reported for
the file (`solu_line`) is the objective of the file, not of the unrounded model.
"""

from __future__ import annotations

import re
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from solvers._model import CliqueModel

#: Column names MPS readers take as they are: no blanks, printable ASCII, at most 255 characters, and no
#: leading character that some readers treat specially (``$``, ``*``, ``-``, ``+``).
_SAFE_NAME = re.compile(r"[A-Za-z0-9_.][A-Za-z0-9_.+\-\[\]()<>=:@#/|]{0,254}")
#: Name of the cap row (sec. 6); clique rows are ``c1``, ``c2``, ...
CAP_ROW = "cap"
#: The comment lines a file starts with (module notes).
HEADER = (
    "* Free MPS (names up to 255 characters; read it as free format).\n"
    "* Minimises the negated importance sum of eq. 3a: the packing's value is minus the objective.\n"
)
#: Largest relative difference between a written coefficient and the model's (HiGHS writes 15 digits).
WRITE_TOLERANCE = 1e-14

SoluStatus = Literal["opt", "best", "inf", "unkn"]


@dataclass(frozen=True)
class MpsFile:
    """An MPS file of a `CliqueModel`, as HiGHS wrote it.

    Attributes
    ----------
    text : str
        The file's content.
    columns : tuple of str
        The column name of each model item, in item order.
    rows : tuple of str
        The row names: ``c1`` ... ``cR`` for the clique rows, then `CAP_ROW` when the model has a cap.
    costs : (I,) float array
        The objective coefficients as read back from ``text`` (the model's negated weights to 15 significant
        digits): the objective of the file, minimised, is ``costs @ x``.
    """

    text: str
    columns: tuple[str, ...]
    rows: tuple[str, ...]
    costs: np.ndarray

    def objective(self, items: Sequence[int]) -> float:
        """The file's (minimised) objective at the packing ``items`` (model indices): ``sum(costs[items])``,
        the negated importance sum."""
        return float(np.sum(self.costs[np.asarray(items, dtype=np.int64)], dtype=np.float64))


def column_names(labels: Sequence[str]) -> tuple[str, ...]:
    """MPS column names for items labelled ``labels``: the labels themselves when every one is a safe,
    distinct MPS name (`_SAFE_NAME`), else ``x0``, ``x1``, ... for all (the caller keeps the mapping)."""
    if len(set(labels)) == len(labels) and all(_SAFE_NAME.fullmatch(label) for label in labels):
        return tuple(labels)
    return tuple(f"x{i}" for i in range(len(labels)))


def write_mps(model: CliqueModel, *, name: str, columns: Sequence[str] | None = None) -> MpsFile:
    """The MPS text of ``min -w.x  s.t.  matrix() @ x <= upper(),  x binary``: eq. 3 after presolve (sec. 6),
    its maximisation written as the minimisation of the negated objective.

    Parameters
    ----------
    model : CliqueModel
        The presolved model; its `CliqueModel.matrix` and `CliqueModel.upper` give the rows exactly as the
        backends see them (one at-most-one row per clique, then the cap row).
    name : str
        The problem name (the MPS ``NAME`` line), e.g. the file stem.
    columns : sequence of str, optional
        A safe MPS name for each item (`column_names`); default ``x0``, ``x1``, ...

    Returns
    -------
    MpsFile
        With the coefficients as written (HiGHS writes 15 significant digits, see the module notes).

    Raises
    ------
    ValueError
        When HiGHS refuses the model or the file it wrote does not read back as the same model.

    Notes
    -----
    No ``OBJSENSE`` section: the default sense, minimisation, of the negated weights (module notes).
    Variables are integer columns (``MARKER INTORG``) with ``BV`` bounds. Free MPS (module notes).
    """
    import highspy

    from solvers._highs_model import highs_lp

    n_items = model.n_items
    columns = tuple(f"x{i}" for i in range(n_items)) if columns is None else tuple(columns)
    if len(columns) != n_items:
        raise ValueError(f"write_mps: {len(columns)} column names for {n_items} items")
    matrix, upper = model.matrix(), model.upper()
    rows = tuple(f"c{r + 1}" for r in range(model.n_rows)) + ((CAP_ROW,) if model.cap is not None else ())
    lp = highs_lp(
        highspy, matrix, np.full(matrix.shape[0], -np.inf), upper, -model.weights,
        np.zeros(n_items), np.ones(n_items), maximise=False,
    )  # fmt: skip
    lp.col_names_, lp.row_names_, lp.model_name_ = list(columns), list(rows), name
    with tempfile.TemporaryDirectory(prefix="harness-mps-") as folder:
        path = Path(folder) / "model.mps"
        highs = _silent(highspy)
        _ok(highspy, highs.passModel(lp), "passModel")
        _ok(highspy, highs.writeModel(str(path)), "writeModel")
        text = HEADER + path.read_text(encoding="ascii")  # comment lines: readers skip them
        back = _silent(highspy)
        _ok(highspy, back.readModel(str(path)), "readModel")
        read = back.getLp()
    costs = np.asarray(read.col_cost_, dtype=np.float64)
    _check_same(model, matrix, upper, columns, read, costs, highspy)
    return MpsFile(text, columns, rows, costs)


def solu_line(status: SoluStatus, name: str, value: float | None = None) -> str:
    """One line of a MIPLIB ``.solu`` file: ``=opt=  NAME  VALUE`` (proved optimal), ``=best= NAME VALUE``
    (best known), ``=inf=  NAME`` (infeasible) or ``=unkn= NAME`` (nothing known).

    ``VALUE`` is in the file's own objective sense (here the minimised negation of eq. 3a, as written),
    printed with 17 significant digits (``repr`` of the double) so that it reads back as the same float.
    """
    if status in ("opt", "best"):
        if value is None or not np.isfinite(value):
            raise ValueError(f"solu_line: ={status}= needs a finite value, got {value!r}")
        return f"{'=' + status + '=':<7}{name}  {float(value)!r}"
    if status in ("inf", "unkn"):
        return f"{'=' + status + '=':<7}{name}"
    raise ValueError(f"solu_line: unknown status {status!r}; one of opt, best, inf, unkn")


def _silent(highspy):
    highs = highspy.Highs()
    highs.setOptionValue("output_flag", False)
    return highs


def _ok(highspy, status, call: str) -> None:
    """HiGHS did it (a warning, such as "no row names" for a model without rows, is checked by reading the
    file back)."""
    if status == highspy.HighsStatus.kError:
        raise ValueError(f"write_mps: HiGHS {call} answered {status}")


def _check_same(model, matrix, upper, columns, read, costs, highspy) -> None:
    """The model HiGHS read back from the file is ``model``: same rows, bounds, names and integrality,
    the negated objective coefficients to `WRITE_TOLERANCE`, minimised."""
    import scipy.sparse as sp

    a = read.a_matrix_
    if a.format_ == highspy.MatrixFormat.kRowwise:
        back = sp.csr_matrix((a.value_, a.index_, a.start_), shape=(read.num_row_, read.num_col_))
    else:
        back = sp.csc_matrix((a.value_, a.index_, a.start_), shape=(read.num_row_, read.num_col_))
    problems = []
    if read.sense_ != highspy.ObjSense.kMinimize:
        problems.append("the objective sense is not MIN")
    if back.shape != matrix.shape or (back != matrix).nnz:
        problems.append("the rows differ")
    if not np.array_equal(np.asarray(read.row_upper_), upper):
        problems.append("the right-hand sides differ")
    if tuple(read.col_names_) != tuple(columns):
        problems.append("the column names differ")
    if not (
        np.array_equal(read.col_lower_, np.zeros(model.n_items))
        and np.array_equal(read.col_upper_, np.ones(model.n_items))
    ):
        problems.append("the bounds are not binary")
    if any(kind != highspy.HighsVarType.kInteger for kind in read.integrality_):
        problems.append("a column is not integer")
    scale = np.maximum(np.abs(model.weights), 1.0)
    if costs.shape != model.weights.shape or np.any(np.abs(costs + model.weights) > WRITE_TOLERANCE * scale):
        problems.append("the objective coefficients differ beyond the written precision")
    if problems:
        raise ValueError(f"write_mps: the MPS file does not read back as the model: {'; '.join(problems)}")
