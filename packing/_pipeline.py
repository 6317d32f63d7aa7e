"""Algorithm 1 as one checked pipeline: analyse the rig, run the expression sequence, check it independently.

Every caller that packs a rig (a benchmark cell, a replay's reference sequence, an exported reference, the
artist's ``harness pack``) runs the same three steps of Carrigan et al. 2020: the rig analysis of sec. 4
(binary blendshapes, eq. 2; importance, eq. 4; symmetry pairs, sec. 4.4; the presolved problem, sec. 6),
the sequence of Algorithm 1 on that analysis, and the independent checker (`packing.check`) with the
same packing parameters and the analysis's symmetry pairs. `Pipeline` holds what the steps share, so that
no caller checks with other parameters than it packed with; what a caller does between the steps (keep
the expressions as they come, stop at a solver's error, word its failures) stays the caller's.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from packing._analysis import Analysis, analyse
from packing._check import check
from packing._importance import MissingTargetWarning
from packing._sequence import PackingSolver, sequence
from packing._solution import Expression, Termination

if TYPE_CHECKING:
    import numpy as np

    from rigs import Rig


@dataclass(frozen=True)
class Pipeline:
    """One rig analysed with one set of packing parameters, ready to sequence and check.

    Attributes
    ----------
    rig : Rig
        The template rig.
    params : mapping
        The `packing.PackingParams` fields the rig was analysed with, given again to the checker.
    analysis : Analysis
        The rig's analysis (sec. 4): its symmetry pairs are those the checker enforces.
    analysis_time : float
        Seconds the analysis took (the ``analysis_time`` a benchmark records apart from the solves).
    """

    rig: Rig
    params: Mapping[str, Any]
    analysis: Analysis
    analysis_time: float

    @classmethod
    def analyse(cls, rig: Rig, target_neutral: np.ndarray | None = None, **params: Any) -> Pipeline:
        """Analyse ``rig`` (`packing.analyse`), timed.

        Without ``target_neutral`` the distortion importance (eq. 6) is 0 by design, not by mistake, so its
        `MissingTargetWarning` is not raised here.

        Raises
        ------
        ValueError
            For bad packing parameters.
        """
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", MissingTargetWarning)
            clock = time.perf_counter()
            analysis = analyse(rig, target_neutral, **params)
            analysis_time = time.perf_counter() - clock
        return cls(rig, dict(params), analysis, analysis_time)

    def sequence(
        self,
        solver: PackingSolver,
        *,
        jmax: int | None = None,
        time_limit: float | None = None,
        seed: int = 0,
        on_expression: Callable[[Expression], None] | None = None,
    ) -> list[Expression]:
        """The expressions of Algorithm 1 with ``solver`` on the analysis (`packing.sequence`)."""
        return sequence(
            self.rig,
            solver,
            analysis=self.analysis,
            jmax=jmax,
            time_limit=time_limit,
            seed=seed,
            on_expression=on_expression,
        )

    def check(
        self,
        expressions: Iterable[Any],
        *,
        overlap: float,
        maximal: bool = True,
        rejected: Mapping[int, Iterable[str]] | None = None,
    ) -> None:
        """Check ``expressions`` from the rig's raw deltas (`packing.check`) with the analysis's symmetry
        pairs and the parameters the rig was analysed with.

        Parameters
        ----------
        expressions : iterable of Expression
            Or anything with their ``index``, ``shapes``, ``extra_examples``, ``objective``, ``bound`` and
            ``termination``.
        overlap : float
            The share of an item's active vertices the solver may overlap (its declared
            ``capabilities.max_overlap``; 0 is eq. 3b).
        maximal : bool
            Every expression of a solver that ran to its end must be maximal.
        rejected : mapping, optional
            1-based expression -> shapes not counted as fitting it (rejected by the artist, sec. 4.5.3, or
            used before the instance a replay solves).

        Raises
        ------
        packing.CheckError
            For the first expression that breaks a rule.
        """
        check(
            self.rig,
            expressions,
            pairs=self.analysis.pairs,
            overlap=overlap,
            maximal=maximal,
            rejected=rejected,
            **self.params,
        )


def failed_expression(expressions: Sequence[Expression]) -> Expression | None:
    """The first expression whose solver reported an error (``Termination.ERROR``: the sequence stops
    there, its expression empty)."""
    return next((e for e in expressions if e.termination is Termination.ERROR), None)
