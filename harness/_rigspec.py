"""Rig arguments on the command line: a rig file or folder `rigs.load` reads, or a generator preset name."""

from __future__ import annotations

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
