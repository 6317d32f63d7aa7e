"""The rig formats this package reads and writes, entered in the table of formats (`rigs._format_table`) in
the order they are recognised; `rigs._formats` imports this module before it looks any format up.

* ``npz``: ``*.npz``, the native archive (`rigs._npz`), loaded verbatim;
* ``gltf``: ``*.gltf``, ``*.glb``, morph targets of one mesh primitive (`rigs._gltf`);
* ``usd``: ``*.usd``, ``*.usda``, ``*.usdc``, UsdSkel blend shapes of one mesh (`rigs._usd`, needs the
  ``usd`` extra);
* ``target``: a folder with ``*.target`` files, a ``*.zip`` (or, with ``format="target"``, any zip such as
  a wheel), or a ``*.json`` manifest with ``base``: a MakeHuman/MPFB target set (`rigs._target`);
* ``obj-folder``: a folder with ``*.obj`` files, its ``rig.json`` (a manifest with ``shapes``), or its
  neutral ``*.obj`` (the other OBJ files of its folder are the blendshapes) (`rigs._obj_folder`).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from rigs._format_table import RigFormat, enter
from rigs._obj_folder import MANIFEST_LIMIT, load_obj_folder, load_obj_neutral
from rigs._rig import Rig
from rigs._safe import read_json
from rigs._target import TARGET_SUFFIXES
from rigs._usd import USD_SUFFIXES


def _manifest_keys(path: Path) -> set[str]:
    content = read_json(path, limit=MANIFEST_LIMIT, what="manifest")
    return set(content) if isinstance(content, dict) else set()


def _holds_targets(path: Path) -> bool:
    if path.is_dir():
        return any(entry.name.endswith(TARGET_SUFFIXES) for entry in path.rglob("*"))
    return path.suffix.lower() == ".zip" or "shapes" not in _manifest_keys(path)


def _holds_objs(path: Path) -> bool:
    if path.is_dir():
        return any(entry.suffix.lower() == ".obj" for entry in path.iterdir())
    return path.suffix.lower() == ".obj" or "shapes" in _manifest_keys(path)


def _target_reader(path: Path) -> str:
    if path.is_dir():
        return "rigs._target:load_target_folder"
    if path.suffix.lower() == ".json":
        return "rigs._target:load_target_manifest"
    return "rigs._target:load_target_zip"


def _obj_reader(path: Path) -> Callable[..., Rig]:
    if path.is_dir():
        return load_obj_folder
    return load_obj_neutral if path.suffix.lower() == ".obj" else _load_obj_manifest


def _load_obj_manifest(path: Path, *, neutral: str | Path | None = None) -> Rig:
    """The OBJ folder of a ``rig.json`` manifest."""
    return load_obj_folder(path.parent, neutral=neutral)


enter(
    RigFormat(
        "npz",
        (".npz",),
        "rigs._npz:load_npz",
        write="rigs._npz:save_npz",
        write_suffixes=(".npz",),
        self_contained=(".npz",),
        verbatim=True,
    )
)
enter(RigFormat("gltf", (".gltf", ".glb"), "rigs._gltf:load_gltf", self_contained=(".glb",)))
enter(
    RigFormat(
        "usd", USD_SUFFIXES, "rigs._usd:load_usd", write="rigs._usd:save_usd", write_suffixes=USD_SUFFIXES
    )
)
enter(
    RigFormat(
        "target",
        (".zip", ".json"),
        "",
        read_for=_target_reader,
        claims=_holds_targets,
        self_contained=(".zip",),
    )
)
enter(
    RigFormat(
        "obj-folder",
        (".obj", ".json"),
        "",
        read_for=_obj_reader,
        write="rigs._obj_folder:save_obj_folder",
        write_suffixes=("",),
        claims=_holds_objs,
    )
)
