"""The native rig format: a NumPy ``.npz`` archive.

The archive holds exactly the keys ``neutral`` (N, 3) float64, ``deltas`` (K, N, 3) float64,
``triangles`` (T, 3) int64, ``names`` (K,) unicode, ``region__<name>`` (int64 vertex indices) for
each region, and ``units`` (a unicode scalar: ``provenance.units``) when the length unit is known. Nothing
else is stored: ``faces`` (original polygons), ``landmarks`` and the rest of the records (``provenance``,
``surface``, ``truth``) do not survive; every array does, bit for bit.
"""

from __future__ import annotations

import io
import zipfile
from pathlib import Path

import numpy as np

from registry import atomic_write
from rigs._provenance import Provenance
from rigs._rig import Rig, RigError
from rigs._safe import read_bytes
from rigs._safe_npz import NpzArchive

REQUIRED_KEYS = ("neutral", "deltas", "triangles", "names")
REGION_PREFIX = "region__"
#: The optional key holding the length unit.
UNITS_KEY = "units"


def save_npz(rig: Rig, path: str | Path) -> Path:
    """Write ``rig`` to ``path`` (compressed, written to a temporary file then moved into place).

    Raises
    ------
    RigError
        When a region name is empty (it would not make a key).
    """
    path = Path(path)
    arrays = {
        "neutral": rig.neutral,
        "deltas": rig.deltas,
        "triangles": rig.triangles,
        "names": np.array(rig.names, dtype=np.str_) if rig.names else np.zeros(0, dtype="<U1"),
    }
    for name, indices in rig.regions.items():
        if not name:
            raise RigError(f"{path}: a region has an empty name")
        arrays[REGION_PREFIX + name] = indices
    if rig.provenance.units not in (None, "", "unknown"):
        arrays[UNITS_KEY] = np.array(rig.provenance.units, dtype=np.str_)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, lambda stream: np.savez_compressed(stream, **arrays))
    return path


def load_npz(path: str | Path) -> Rig:
    """Read a rig written by :func:`save_npz`.

    Returns
    -------
    Rig with ``provenance = Provenance(source=str(path), format="npz", units=...)`` (the stored unit,
    ``unknown`` when none is).

    Raises
    ------
    RigError
        One line naming the file and the problem: missing file or not a regular file, not an ``.npz``
        archive, a missing or unexpected key, a key holding Python objects, a member whose header does
        not match its size or that is too large for the file (see :class:`rigs._safe_npz.NpzArchive`;
        nothing is allocated before these checks), or a rig that fails validation.
    """
    path = Path(path)
    data = read_bytes(path)
    if not data.startswith(b"PK") and data.startswith(b"\x93NUMPY"):
        raise RigError(
            f"{path}: holds a single array, not a rig archive (.npz with keys {', '.join(REQUIRED_KEYS)})"
        )
    if not zipfile.is_zipfile(io.BytesIO(data)):  # np.load would blame pickling
        raise RigError(f"{path}: not a NumPy .npz archive (not a zip file; truncated or another format?)")
    with NpzArchive(data, str(path)) as archive:
        keys = set(archive.headers)
        missing = [key for key in REQUIRED_KEYS if key not in keys]
        if missing:
            raise RigError(f"{path}: missing key {missing[0]!r} (a rig needs {', '.join(REQUIRED_KEYS)})")
        known = {*REQUIRED_KEYS, UNITS_KEY}
        unexpected = sorted(key for key in keys - known if not key.startswith(REGION_PREFIX))
        if unexpected:
            raise RigError(
                f"{path}: unexpected key {unexpected[0]!r} (only {', '.join(REQUIRED_KEYS)}, region__*, "
                f"{UNITS_KEY})"
            )
        arrays = {key: archive.read(key) for key in sorted(keys)}
    names = arrays["names"]
    if names.ndim != 1 or names.dtype.kind not in "US":
        raise RigError(
            f"{path}: 'names' must be a 1-D string array, got dtype {names.dtype} shape {names.shape}"
        )
    if names.dtype.kind == "S":
        try:
            names = np.char.decode(names, "utf-8")
        except UnicodeDecodeError as error:
            raise RigError(f"{path}: 'names' holds bytes that are not UTF-8 text ({error.reason})") from None
    regions = {
        key[len(REGION_PREFIX) :]: value for key, value in arrays.items() if key.startswith(REGION_PREFIX)
    }
    units = arrays.get(UNITS_KEY)
    if units is not None and (units.ndim != 0 or units.dtype.kind != "U" or not str(units)):
        raise RigError(
            f"{path}: '{UNITS_KEY}' must be a text scalar such as 'cm', got a {units.dtype} array of shape "
            f"{units.shape}"
        )
    return Rig(
        neutral=arrays["neutral"],
        deltas=arrays["deltas"],
        triangles=arrays["triangles"],
        names=tuple(str(name) for name in names.tolist()),
        regions=regions,
        provenance=Provenance(
            source=str(path), format="npz", units="unknown" if units is None else str(units)
        ),
    )
