"""The rig files of a run, checked before any cell: each reads, has blendshapes and takes every warp of the
grid (a rig argument itself is resolved by `rigs.resolve`)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

from registry import HarnessError

if TYPE_CHECKING:
    from rigs import Rig, RigInputs, Warp


def check_rig_files(arguments: Iterable[str], warps: Iterable[str], *, no_warp: str) -> dict[str, RigInputs]:
    """Every rig file among ``arguments`` reads and has blendshapes, and every warp finds the centres it needs
    on it.

    Run before any cell, so that a rig without the landmarks or regions a warp needs (e.g. ``big-eyes`` on
    a rig without eyelid regions) is one error up front, not one failed cell per solver.

    Returns
    -------
    dict
        Per rig file or folder argument, what its read opened (`rigs.load_with_inputs`): its content.

    Raises
    ------
    rigs.RigError
        For an unreadable file (naming it and the problem).
    HarnessError
        For a rig without blendshapes.
    ValueError
        For a warp that cannot be applied, naming the warp, the rig, the missing centre and the warps
        that do apply.
    """
    import rigs

    warps = [name for name in warps if name != no_warp]
    found = {}
    for argument in arguments:
        if not rigs.is_rig_path(argument):
            continue
        rig, found[argument] = rigs.load_with_inputs(argument)
        if not rig.n_shapes:
            raise HarnessError(f"rig {argument}: it has no blendshapes, so there is nothing to pack")
        for name in warps:
            try:
                rigs.WARPS[name].resolve(rig)
            except rigs.RigError as error:
                usable = [other for other in sorted(rigs.WARPS) if _applies(rigs.WARPS[other], rig)]
                raise HarnessError(
                    f"--warps {name}: {error}; warps that apply to this rig: {', '.join([*usable, no_warp])}"
                ) from None
    return found


def _applies(warp: Warp, rig: Rig) -> bool:
    import rigs

    try:
        warp.resolve(rig)
    except rigs.RigError:
        return False
    return True
