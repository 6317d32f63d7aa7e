"""What ``harness instances export`` replays: one reference sequence per rig and packing setting.

An argument names either a rig (resolved as ``harness pack`` resolves it, `rigs.resolve`)
with the packing parameters of the command line, or a finished run directory (holding ``run.json``), whose
configuration gives the sequences: one per distinct (rig, warp, packing setting) of its grid and
variations, with the run's ``jmax``, per-solve time limit, seed, artist constraints and regions, and the
warped target's neutral in the importance (eq. 6) exactly as the run's cells analysed it
(`harness._cell`). Solvers and repetitions of the run do not make further sequences: the export replays
every setting with its one reference solver.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from registry import HarnessError

if TYPE_CHECKING:
    import numpy as np

    from harness._grid import CellSpec
    from rigs import Rig

#: Characters kept in a file-name prefix; anything else becomes ``_``.
_UNSAFE = re.compile(r"[^A-Za-z0-9_.+-]+")
#: The `harness._grid.CellSpec` fields that decide a reference sequence, which tell the sequences of one run
#: apart: the rig (its content and generator seed), the warp, every packing parameter, the sequence's length
#: and its solves' time limit.
SEQUENCE_FIELDS = (
    "rig", "rig_seed", "rig_digest", "warp", "mu", "alpha", "beta", "symmetry", "importance", "cap",
    "distortion", "together", "apart", "regions", "jmax", "time_limit",
)  # fmt: skip
#: The fields that do not: the cell's solver and its settings and seed (the reference sequence is the exact
#: reference solver's, whose tie-broken optimum no seed changes), its repetition, its transfers and their
#: training examples and the animation frames they retarget, whether it replays a reference, and the order
#: its items are given in.
OTHER_FIELDS = (
    "solver", "solver_settings", "seed", "repetition", "transfers", "j_values", "examples", "scan_seed",
    "frames", "mode", "permutation",
)  # fmt: skip


@dataclass(frozen=True)
class Sequence:
    """One reference sequence to replay (Algorithm 1 on one rig with one packing setting).

    Attributes
    ----------
    prefix : str
        File-name prefix of its instances (``PREFIX-e01.mps``, ...).
    rig_argument : str
        The rig as named on the command line or in ``run.json``.
    rig : Rig
        The template rig.
    target_neutral : (N, 3) array or None
        The warped target's neutral (a run's warp), for the distortion importance (eq. 6).
    warp : str
        The run's warp, or ``none``.
    params : dict
        Keyword arguments of `packing.analyse` (`packing.PackingParams` names).
    jmax : int or None
    time_limit : float or None
        Seconds per solve.
    seed : int
        The reference solver's seed.
    inputs : tuple of Path
        The files and folders the rig argument reads, which the output folder must stay apart from.
    rig_seed : int
        The generator seed of a preset rig (and its actor).
    """

    prefix: str
    rig_argument: str
    rig: Rig
    target_neutral: np.ndarray | None
    warp: str
    params: dict[str, Any]
    jmax: int | None
    time_limit: float | None
    seed: int
    inputs: tuple[Path, ...] = field(default=())
    rig_seed: int = 0

    def describe(self) -> dict[str, Any]:
        """JSON-ready description (``instances.json``): rig and its generator seed, warp, the parameters,
        jmax, time limit, seed."""
        params = {
            key: (
                {name: len(indices) for name, indices in value.items()}
                if key == "regions" and isinstance(value, Mapping)
                else value
            )
            for key, value in self.params.items()
        }
        return {
            "prefix": self.prefix,
            "rig": self.rig_argument,
            "rig_seed": self.rig_seed,
            "warp": self.warp,
            "params": _plain(params),
            "jmax": self.jmax,
            "time_limit": self.time_limit,
            "seed": self.seed,
        }


def is_run_directory(argument: str) -> bool:
    """Whether ``argument`` is a run directory (a folder holding ``run.json``)."""
    from harness._run_file import RUN_FILE

    return (Path(argument) / RUN_FILE).is_file()


def rig_prefix(argument: str) -> str:
    """File-name prefix for a rig argument: a preset's name, a file's stem, a folder's name (unsafe
    characters replaced by ``_``)."""
    path = Path(argument)
    text = path.stem if path.suffix and not path.is_dir() else path.name or argument
    return _UNSAFE.sub("_", text).strip("_.") or "rig"


def from_rig(
    argument: str, *, params: dict[str, Any], jmax: int | None, time_limit: float | None, seed: int
) -> Sequence:
    """The one sequence of a rig argument with the command line's packing parameters.

    Raises
    ------
    rigs.RigError
        For a rig that does not exist or cannot be read (one line naming it).
    """
    import rigs

    rig = rigs.resolve(argument, seed=seed)
    return Sequence(
        prefix=rig_prefix(argument),
        rig_argument=argument,
        rig=rig,
        target_neutral=None,
        warp="none",
        params=dict(params),
        jmax=jmax,
        time_limit=time_limit,
        seed=seed,
        inputs=tuple(rigs.argument_paths(argument)),
        rig_seed=seed,
    )


def from_run(run: Path, *, rig: str | None, time_limit: float | None) -> list[Sequence]:
    """The sequences of a run directory's configuration (see the module notes), only those of rig ``rig``
    (as ``run.json`` names it) when given; ``time_limit`` replaces the run's per-solve limit when given.

    Raises
    ------
    ValueError
        For an unreadable ``run.json``, a ``rig`` the run does not have (listing those it has), or a rig
        file whose content changed since the run.
    """
    import rigs
    from harness._cell_rigs import RigChangedError, packing_params, rig_pair
    from harness._grid import NO_WARP, RunConfig
    from harness._run_file import read_run

    info = read_run(run)
    try:
        config = RunConfig.from_dict(info["config"])
    except (KeyError, TypeError) as error:
        raise HarnessError(f"{run}: run.json holds no usable config ({error})") from None
    if rig is not None and rig not in config.rigs:
        raise HarnessError(f"--rig {rig!r}: the run in {run} has rigs {', '.join(config.rigs)}")
    chosen: dict[tuple[Any, ...], CellSpec] = {}
    for spec in config.cells(info.get("rig_digests") or {}):
        if rig is None or spec.rig == rig:
            chosen.setdefault(tuple(repr(getattr(spec, name)) for name in SEQUENCE_FIELDS), spec)
    specs = list(chosen.values())
    sequences = []
    for spec in specs:
        try:
            template, target = rig_pair(spec)
        except RigChangedError as error:
            raise HarnessError(str(error)) from None
        sequences.append(
            Sequence(
                prefix=_run_prefix(spec, specs),
                rig_argument=spec.rig,
                rig=template,
                target_neutral=None if spec.warp == NO_WARP else target.neutral,
                warp=spec.warp,
                params=packing_params(spec),
                jmax=spec.jmax,
                time_limit=spec.time_limit if time_limit is None else time_limit,
                seed=spec.seed,
                inputs=tuple(rigs.argument_paths(spec.rig)),
                rig_seed=spec.rig_seed,
            )
        )
    return sequences


def _run_prefix(spec: CellSpec, specs: list[CellSpec]) -> str:
    """``rig``, with ``-warp`` when the run has several warps of the rig, and ``-sN`` (the sequence's
    place among the rig's and warp's, by seed and setting) when it has several."""
    prefix = rig_prefix(spec.rig)
    same_rig = [other for other in specs if other.rig == spec.rig]
    if len({other.warp for other in same_rig}) > 1:
        prefix += "-" + _UNSAFE.sub("_", spec.warp)
    same = [other for other in same_rig if other.warp == spec.warp]
    if len(same) > 1:
        prefix += f"-s{same.index(spec) + 1}"
    return prefix


def _plain(value: Any) -> Any:
    """Tuples as lists, recursively (JSON-ready)."""
    if isinstance(value, dict):
        return {key: _plain(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(item) for item in value]
    return value
