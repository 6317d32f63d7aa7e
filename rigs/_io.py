"""Loading and saving rigs: one front door over the native ``.npz`` and the interchange formats.

Formats, told apart by the path (``format=`` overrides):

* ``*.npz``: ``npz``, the native archive (:mod:`rigs._npz`), loaded verbatim;
* ``*.gltf``, ``*.glb``: ``gltf``, morph targets of one mesh primitive (:mod:`rigs._gltf`);
* a folder with ``*.target`` files, a ``*.zip`` (or, with ``format="target"``, any zip such as a wheel),
  or a ``*.json`` manifest with ``base``: ``target``, a MakeHuman/MPFB target set (:mod:`rigs._target`);
* a folder with ``*.obj`` files, its ``rig.json``, or its neutral ``*.obj`` (the other OBJ files of its
  folder are the blendshapes): ``obj-folder``, neutral + one OBJ per blendshape (:mod:`rigs._obj_folder`);
* ``*.usd``, ``*.usda``, ``*.usdc``: ``usd``, UsdSkel blend shapes of one mesh (:mod:`rigs._usd`, needs
  the ``usd`` extra).

Every reader treats its files as untrusted (see :mod:`rigs._safe`): it reads only regular files inside the
rig's folder, sizes every array against what the files can hold before allocating it, and turns every
problem into a one-line `RigError` naming the file, the shape and what is wrong; what it leaves out or
doubts is named in a `RigWarning`.

Interchange formats are cleaned the same way after reading: displacements shorter than a relative
noise floor are zeroed (Carrigan et al. 2020, sec. 4.1, needs empty shapes to be truly empty), and the
report lands in ``meta``: ``meta["noise"]`` (floor and zeroed counts per shape), ``meta["empty_shapes"]``
(kept, never dropped) and ``meta["degenerate_triangles"]`` (reported, not fatal).
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from dataclasses import replace
from inspect import Parameter, signature
from pathlib import Path
from typing import Any

import numpy as np

from rigs._npz import load_npz, save_npz
from rigs._obj_folder import MANIFEST_LIMIT, load_obj_folder, load_obj_neutral, save_obj_folder
from rigs._rig import Rig, RigError, vector_lengths
from rigs._safe import read_text, regular_file
from rigs._target import TARGET_SUFFIXES, load_target_folder, load_target_manifest, load_target_zip
from rigs._usd import USD_SUFFIXES, load_usd, save_usd

DEFAULT_NOISE_FLOOR = 1e-6
#: Displacements shorter than this many rounding steps of the file's coordinates are noise: two
#: coordinates rounded to the same step differ by at most one step each, ``sqrt(3)`` steps in length.
ROUNDING_STEPS = 2.0

FORMATS = ("npz", "obj-folder", "gltf", "target", "usd")


def detect_format(path: str | Path) -> str:
    """The format of ``path`` (see the module table); raises `RigError` when it cannot tell."""
    path = Path(path)
    suffix = path.suffix.lower()
    if not os.path.lexists(path):
        raise RigError(f"{path}: no such file or folder")
    if not path.is_dir():
        regular_file(path)  # a dangling link, a FIFO or a device is named as such
    if path.is_dir():
        if any(p.name.endswith(TARGET_SUFFIXES) for p in path.rglob("*")):
            return "target"
        if any(p.suffix.lower() == ".obj" for p in path.iterdir()):
            return "obj-folder"
        raise RigError(f"{path}: folder holds neither OBJ files nor .target files")
    if suffix == ".npz":
        return "npz"
    if suffix in (".gltf", ".glb"):
        return "gltf"
    if suffix in USD_SUFFIXES:
        return "usd"
    if suffix == ".zip":
        return "target"
    if suffix == ".json":
        return "obj-folder" if "shapes" in _json_keys(path) else "target"
    if suffix == ".obj":
        return "obj-folder"
    raise RigError(
        f"{path}: unknown rig format {suffix or '(no suffix)'!r} "
        "(.npz, .gltf, .glb, .usd, .usda, .usdc, .zip, .json, a folder, or the neutral .obj of a folder "
        "of OBJs)"
    )


def _json_keys(path: Path) -> set[str]:
    text = read_text(path, limit=MANIFEST_LIMIT, why="a manifest")
    try:
        content = json.loads(text)
    except (ValueError, RecursionError) as error:
        raise RigError(f"{path}: not a readable JSON manifest ({type(error).__name__}: {error})") from None
    return set(content) if isinstance(content, dict) else set()


def load(
    path: str | Path,
    *,
    format: str | None = None,
    noise_floor: float | None = None,
    units: str | None = None,
    **options: Any,
) -> Rig:
    """Load a rig; the format follows from the path (see the module docstring).

    Parameters
    ----------
    path : path
        File or folder.
    format : {"npz", "obj-folder", "gltf", "target", "usd"}, optional
        Overrides detection.
    noise_floor : float, optional
        Displacements shorter than ``noise_floor`` times the neutral's bounding-box diagonal are zeroed.
        Default ``1e-6`` for interchange formats; ``.npz`` files are loaded verbatim unless it is given.
    units : str, optional
        Length unit recorded in ``meta["units"]``, overriding what the file says (OBJ and ``.npz`` say
        nothing; glTF says metres; manifests may say).
    **options
        Format options. ``obj-folder``: ``neutral`` (file name, default ``neutral.obj``).
        ``gltf``: ``mesh``, ``primitive``, ``weld``, ``weld_tolerance``, ``transform``
        (see :func:`rigs._gltf.load_gltf`). ``usd``: ``mesh`` (see :func:`rigs._usd.load_usd`).
        ``target``: ``crop_rings``; ``base`` (folders, archives);
        ``targets`` (member glob) and ``group_regions`` (OBJ group -> region name) for archives
        (see :mod:`rigs._target`).

    Returns
    -------
    Rig, with ``meta["source"]``, ``meta["format"]``, ``meta["units"]`` where known, and the noise,
    empty-shape and degenerate-triangle report.

    Raises
    ------
    RigError
        One line naming the file (and the shape, where there is one) and what is wrong with it, or the
        unknown option.

    Warns
    -----
    RigWarning
        For what the reader leaves out or doubts (see each reader).

    Examples
    --------
    >>> rig = load("face/")                       # doctest: +SKIP
    >>> rig = load("head.glb", mesh="Head", weld=True)  # doctest: +SKIP
    """
    path = Path(path)
    kind = format or detect_format(path)
    if kind not in FORMATS:
        raise RigError(f"{path}: unknown format {kind!r} (one of {', '.join(FORMATS)})")
    reader = _reader(path, kind)
    accepted = [
        name
        for name, parameter in signature(reader).parameters.items()
        if parameter.kind is Parameter.KEYWORD_ONLY
    ]
    unknown = sorted(set(options) - set(accepted))
    if unknown:
        listed = ", ".join(accepted) or "none"
        raise RigError(f"{path}: unknown option {unknown[0]!r} for {kind} (accepted: {listed})")
    rig = reader(path, **options)
    if noise_floor is None:
        noise_floor = 0.0 if kind == "npz" else DEFAULT_NOISE_FLOOR
    if noise_floor < 0:
        raise RigError(f"{path}: noise_floor must be >= 0, got {noise_floor}")
    if units is not None:
        rig = replace(rig, meta={**rig.meta, "units": units})
    return with_report(rig, noise_floor)


def _reader(path: Path, kind: str) -> Callable[..., Rig]:
    if kind == "npz":
        return load_npz
    if kind == "gltf":
        from rigs._gltf import load_gltf  # (scipy's graph and spatial modules: only for glTF)

        return load_gltf
    if kind == "usd":
        return load_usd
    if kind == "obj-folder":
        if path.suffix.lower() == ".obj":
            return load_obj_neutral
        return _load_obj_manifest if path.suffix.lower() == ".json" else load_obj_folder
    if path.is_dir():
        return load_target_folder
    return load_target_manifest if path.suffix.lower() == ".json" else load_target_zip


def _load_obj_manifest(path: Path, **options: Any) -> Rig:
    return load_obj_folder(path.parent, **options)


def with_report(rig: Rig, noise_floor: float = DEFAULT_NOISE_FLOOR) -> Rig:
    """``rig`` with sub-floor displacements zeroed and the load report in ``meta``.

    Parameters
    ----------
    rig : Rig
    noise_floor : float
        Relative to the neutral's bounding-box diagonal; 0 zeroes nothing. When ``meta["decimal_step"]``
        says the file rounded its coordinates (OBJ written with fixed decimals), the floor is at least
        `ROUNDING_STEPS` such steps, since absolute positions differenced into deltas carry that error.

    Returns
    -------
    Rig whose ``meta`` gains ``noise`` (``relative_floor``, absolute ``floor``, ``rounding_step``,
    ``zeroed`` per shape), ``empty_shapes`` (names with no displacement left) and
    ``degenerate_triangles`` (count).

    Notes
    -----
    O(K N); one pass over the deltas.
    """
    step = float(rig.meta.get("decimal_step", 0.0) or 0.0)
    floor = max(noise_floor * rig.diagonal(), ROUNDING_STEPS * step) if noise_floor > 0 else 0.0
    deltas = rig.deltas
    zeroed: dict[str, int] = {}
    if floor > 0 and rig.n_shapes:
        lengths = vector_lengths(deltas)
        noise = (lengths < floor) & (lengths > 0)
        counts = noise.sum(axis=1)
        if counts.any():
            deltas = np.where(noise[:, :, None], 0.0, deltas)
            zeroed = {rig.names[k]: int(counts[k]) for k in np.flatnonzero(counts)}
    empty = ~deltas.reshape(rig.n_shapes, -1).any(axis=1) if rig.n_shapes else np.zeros(0, dtype=bool)
    meta = dict(rig.meta)
    meta["noise"] = {
        "relative_floor": float(noise_floor),
        "floor": float(floor),
        "rounding_step": step,
        "zeroed": zeroed,
    }
    meta["empty_shapes"] = [rig.names[k] for k in np.flatnonzero(empty)]
    meta["degenerate_triangles"] = int(len(rig.degenerate_triangles()))
    return replace(rig, deltas=deltas, meta=meta)


def save(rig: Rig, path: str | Path, *, format: str | None = None) -> Path:
    """Save a rig: ``*.npz`` as the native archive, ``*.usd``/``*.usda``/``*.usdc`` as UsdSkel blend shapes
    (:func:`rigs._usd.save_usd`), a folder (no suffix) as one OBJ per blendshape.

    Parameters
    ----------
    rig : Rig
    path : path
        ``name.npz``, ``name.usd[a|c]``, or a folder path without suffix (created; it must not hold other
        OBJ files).
    format : {"npz", "obj-folder", "usd"}, optional
        Overrides the choice by suffix.

    Returns
    -------
    The path written.

    Raises
    ------
    RigError
        When the format cannot be told from the path, or the writer refuses (see
        :func:`rigs._obj_folder.save_obj_folder`).
    """
    path = Path(path)
    kind = format
    if kind is None:
        if path.suffix.lower() == ".npz":
            kind = "npz"
        elif path.suffix.lower() in USD_SUFFIXES:
            kind = "usd"
        elif path.is_dir() or not path.suffix:
            kind = "obj-folder"
        else:
            raise RigError(
                f"{path}: cannot save as {path.suffix!r}; use a .npz or .usd/.usda/.usdc file or a folder "
                "path (OBJ folder)"
            )
    if kind == "npz":
        return save_npz(rig, path)
    if kind == "obj-folder":
        return save_obj_folder(rig, path)
    if kind == "usd":
        return save_usd(rig, path)
    raise RigError(f"{path}: cannot save format {kind!r} (npz, obj-folder or usd)")
