"""Rig format plugins that fail in every way a third party's may, for the tests of `rigs._formats`'s guards
(registered through a ``harness.rig_formats`` entry point each, as an installed distribution would).

``SIDECAR`` reads a generated rig and moves its neutral by a number it reads from ``offset.txt`` beside the
named file with plain ``open``, not through `rigs._safe`: what it read is recorded only because a plugin's
whole folder is.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import rigs
from rigs import RigFormat


def _claims_raise(path: Path) -> bool:
    raise RuntimeError("claims exploded")


def _raising(path: Path) -> rigs.Rig:
    raise RuntimeError("reader exploded")


def _dict(path: Path) -> dict:
    return {"neutral": [[0, 0, 0]]}


def _unchecked(path: Path) -> rigs.Rig:
    rig = object.__new__(rigs.Rig)
    good = rigs.generate("tiny")
    for name in ("neutral", "triangles", "names", "regions", "faces", "landmarks", "provenance", "surface"):
        object.__setattr__(rig, name, getattr(good, name))
    for name in ("load_report", "truth"):
        object.__setattr__(rig, name, None)
    object.__setattr__(rig, "deltas", np.zeros((3, 5, 3)))
    return rig


def _sidecar(path: Path) -> rigs.Rig:
    with open(path.parent / "offset.txt", encoding="utf-8") as stream:  # (not through rigs._safe)
        offset = float(stream.read())
    rig = rigs.generate("tiny")
    return rigs.Rig(rig.neutral + offset, rig.deltas, rig.triangles, rig.names, regions=rig.regions)


CLAIMS_RAISE = RigFormat("claims-raise", (".xyz",), read=_raising, claims=_claims_raise)
RAISING = RigFormat("raising", (".rai",), read=_raising)
DICT = RigFormat("dict", (".dic",), read=_dict)
UNCHECKED = RigFormat("unchecked", (".unc",), read=_unchecked)
NPZ = RigFormat("npz", (".npzz",), read=_raising)
SIDECAR = RigFormat("sidecar", (".side",), read=_sidecar)
NOT_A_FORMAT = 42

ENTRY_POINTS = """[harness.rig_formats]
claims-raise = format_plugins:CLAIMS_RAISE
raising = format_plugins:RAISING
dict = format_plugins:DICT
unchecked = format_plugins:UNCHECKED
npz = format_plugins:NPZ
sidecar = format_plugins:SIDECAR
not-a-format = format_plugins:NOT_A_FORMAT
missing = format_plugins:NO_SUCH_THING
"""
