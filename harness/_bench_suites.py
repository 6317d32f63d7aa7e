"""Timing suites: what ``harness compare --commits`` and ``harness track`` measure.

A suite names groups of instances (a rig, its warp and the packing settings: the subproblems of one
reference sequence, Algorithm 1 with an exact solver, frozen so that every solver and every commit solves
the same problems) and the solvers timed on them, and the transfer methods timed on the group's reference
sequence. ``all`` stands for every solver installed here.
"""

from __future__ import annotations

from dataclasses import dataclass

from harness._grid import DEFAULT_J_VALUES
from harness._settings import expand, split_label
from registry import HarnessError

#: The exact solver whose sequence gives a group's instances.
REFERENCE_SOLVER = "cpsat"


@dataclass(frozen=True)
class Group:
    """The instances of one reference sequence: rig (preset, fetched rig or file), generator seed, warp,
    longest sequence, the solvers timed on it when not all of the suite's (``only``), and whether the
    suite's transfers are timed on it."""

    rig: str
    warp: str = "none"
    seed: int = 0
    jmax: int | None = None
    only: tuple[str, ...] | None = None
    transfers: bool = True

    def times(self, solver: str) -> bool:
        """Whether ``solver`` (a label) is timed on this group's instances."""
        return self.only is None or solver.split("[")[0] in self.only

    @property
    def label(self) -> str:
        """``rig/warp``, as the run tables name a rig's case."""
        return f"{self.rig}/{self.warp}"

    def request(self) -> dict:
        """The probe's description of the group."""
        return {
            "rig": self.rig,
            "warp": self.warp,
            "seed": self.seed,
            "jmax": self.jmax,
            "reference": REFERENCE_SOLVER,
        }


@dataclass(frozen=True)
class Suite:
    """Groups, the solvers timed on their instances and the transfers timed on their sequences."""

    name: str
    groups: tuple[Group, ...]
    solvers: tuple[str, ...]
    transfers: tuple[str, ...] = ()
    j_values: tuple[int, ...] = DEFAULT_J_VALUES
    about: str = ""

    def solver_labels(self) -> list[str]:
        """The solver labels, ``all`` expanded to every solver installed here."""
        import solvers

        labels: list[str] = []
        for request in self.solvers:
            labels.extend(solvers.names() if request == "all" else expand(request))
        return list(dict.fromkeys(labels))

    def transfer_labels(self) -> list[str]:
        """The transfer labels, settings expanded."""
        return list(dict.fromkeys(label for request in self.transfers for label in expand(request)))


def solver_request(label: str) -> dict:
    """The probe's description of a solver label (``cpsat[workers=1]``): name, settings, seed."""
    name, settings = split_label(label)
    return {"label": label, "name": name, "settings": dict(settings), "seed": 0}


#: The exact solvers timed on the large instances (the naive per-vertex model takes seconds there).
EXACT = ("cpsat", "highs", "scip", "cbc-mip", "cbc-pulp")

#: Named suites. ``quick`` is the quick preset's rigs with every solver (sub-millisecond solves, each
#: sample many solves); ``large`` the first expressions of the 1,000-shape film rig, whose solves take
#: 10-100 ms; ``transfer`` the paper rig ``female`` transferred by ebfr and dt; ``ci`` what the CI gate
#: measures in its time budget.
SUITES: dict[str, Suite] = {
    "quick": Suite(
        "quick",
        (Group("tiny", "big-eyes"), Group("arkit52", "big-eyes")),
        ("all",),
        about="tiny and arkit52 (big-eyes), every solver",
    ),
    "large": Suite(
        "large",
        (Group("film", "alien", jmax=8),),
        (*EXACT, "greedy"),
        about="the first 8 expressions of the 1,000-shape film rig (alien), exact solvers and greedy",
    ),
    "transfer": Suite(
        "transfer",
        (Group("female", "alien+character"),),
        (),
        ("ebfr", "dt"),
        about="female (alien+character): ebfr and dt over the reference sequence at every J",
    ),
    "ci": Suite(
        "ci",
        (
            Group("tiny", "big-eyes"),
            Group("arkit52", "big-eyes"),
            Group("film", "alien", jmax=4, only=EXACT, transfers=False),
        ),
        ("all",),
        ("ebfr",),
        about="tiny and arkit52 with every solver, film's first 4 expressions with the exact solvers; "
        "ebfr on tiny and arkit52",
    ),
}


def suite(name: str) -> Suite:
    """The suite called ``name``.

    Raises
    ------
    HarnessError
        For an unknown name (the message lists the suites).
    """
    try:
        return SUITES[name]
    except KeyError:
        raise HarnessError(f"unknown timing suite {name!r} (suites: {', '.join(SUITES)})") from None
