"""Rig arguments on the command line: a rig file or folder `rigs.load` reads, or a generator preset name."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any


def is_rig_file(text: str) -> bool:
    """Whether a rig argument names an existing file or folder (else it must be a preset name)."""
    return Path(text).exists()


def resolve_rig(text: str, *, seed: int = 0) -> Any:
    """The rig a command-line argument names: a loadable file or folder, else a `rigs.PRESETS` name.

    Raises
    ------
    rigs.RigError
        When the file cannot be read (the message names the file and the problem), or when ``text``
        is neither an existing path nor a preset (the message lists the presets).
    """
    import rigs

    if is_rig_file(text):
        return rigs.load(text)
    if text in rigs.PRESETS:
        return rigs.generate(text, seed=seed)
    raise rigs.RigError(
        f"unknown rig {text!r}: not an existing file or folder, and not a preset "
        f"(presets: {', '.join(sorted(rigs.PRESETS))})"
    )


def check_rig_files(arguments: Iterable[str], warps: Iterable[str], *, no_warp: str) -> None:
    """Every rig file among ``arguments`` reads, and every warp finds the centres it needs on it.

    Run before any cell, so that a rig without the landmarks or regions a warp needs (e.g. ``big-eyes`` on
    a rig without eyelid regions) is one error up front, not one failed cell per solver.

    Raises
    ------
    rigs.RigError
        For an unreadable file (naming it and the problem).
    ValueError
        For a warp that cannot be applied, naming the warp, the rig, the missing centre and the warps
        that do apply.
    """
    import rigs

    warps = [name for name in warps if name != no_warp]
    for argument in arguments:
        if not is_rig_file(argument):
            continue
        rig = rigs.load(argument)
        for name in warps:
            try:
                rigs.WARPS[name].resolve(rig)
            except rigs.RigError as error:
                usable = [other for other in sorted(rigs.WARPS) if _applies(rigs.WARPS[other], rig)]
                raise ValueError(
                    f"--warps {name}: {error}; warps that apply to this rig: {', '.join([*usable, no_warp])}"
                ) from None


def _applies(warp: Any, rig: Any) -> bool:
    import rigs

    try:
        warp.resolve(rig)
    except rigs.RigError:
        return False
    return True
