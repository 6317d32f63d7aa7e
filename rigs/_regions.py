"""Named vertex regions: the sketched areas of motion symmetry (Carrigan et al. 2020, sec. 4.4.2).

The paper paints the upper/lower lip and eyelid areas in Maya; here a user gives them as a JSON file of region
name -> vertex indices (or a boolean mask per vertex), or as an OBJ of the rig's mesh whose ``g`` groups are
the selections (the vertices of each group's faces), as any DCC exports a face-set selection.
"""

from __future__ import annotations

from collections.abc import Mapping
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np

from rigs._obj import read_obj
from rigs._rig import RigError
from rigs._safe import read_json, regular_file

#: A regions file larger than this is refused before it is read (a selection of every vertex of a
#: million-vertex mesh as JSON is far smaller).
MAX_REGIONS_BYTES = 256 * 1024 * 1024


def read_regions(path: str | PathLike[str], n_vertices: int | None) -> dict[str, np.ndarray]:
    """Vertex regions from a JSON file or an OBJ's face groups.

    Parameters
    ----------
    path : path
        ``.json``: an object ``{"name": [vertex indices] or [bool per vertex], ...}``. ``.obj``: the rig's
        mesh (same vertex count and order); each ``g`` group is a region holding the vertices of its faces.
    n_vertices : int or None
        Vertex count of the rig the regions select on; None when the rig is not known yet (an OBJ's own
        vertex count is used, and JSON indices are only checked to be non-negative: the regions are checked
        again against each rig they are applied to).

    Returns
    -------
    dict of str -> sorted unique int64 array

    Raises
    ------
    RigError
        Naming the file and the region: missing or unreadable file, not a regular file, malformed content,
        an index outside ``0..n_vertices-1``, an OBJ with another vertex count or without groups.
    """
    path = Path(path)
    if regular_file(path) > MAX_REGIONS_BYTES:
        raise RigError(f"{path}: regions file is larger than {MAX_REGIONS_BYTES >> 20} MiB")
    if path.suffix.lower() == ".obj":
        return _obj_regions(path, n_vertices)
    document = read_json(path, limit=MAX_REGIONS_BYTES, what="regions file")
    if not isinstance(document, Mapping):
        raise RigError(f"{path}: regions JSON must be an object of name -> vertex list")
    return regions_from_mapping(document, n_vertices, str(path))


def regions_from_mapping(
    source: Mapping[str, Any], n_vertices: int | None, origin: str = "regions"
) -> dict[str, np.ndarray]:
    """Validated regions from a mapping of name -> vertex indices or a boolean mask of all vertices
    (``n_vertices`` None: a mask of any length, and no upper bound on the indices).

    Raises
    ------
    RigError
        Naming ``origin`` and the region when an entry is not indices or a mask, or indexes outside the mesh.
    """
    regions = {}
    for name, indices in source.items():
        try:
            array = np.asarray(indices)
            if array.dtype == bool:
                if array.ndim != 1 or n_vertices is not None and array.shape != (n_vertices,):
                    raise TypeError
                array = np.flatnonzero(array)
            if array.ndim != 1 or array.size and not np.issubdtype(array.dtype, np.integer):
                raise TypeError  # (a nested list is no list of indices: it is never flattened)
            array = array.astype(np.int64)
        except (TypeError, ValueError):
            raise RigError(
                f"{origin}: region {name!r} must be a list of vertex indices or "
                f"{'one boolean per vertex' if n_vertices is None else f'{n_vertices} booleans'}"
            ) from None
        if array.size and n_vertices is None and array.min() < 0:
            raise RigError(f"{origin}: region {name!r} holds a negative vertex index")
        if array.size and n_vertices is not None and (array.min() < 0 or array.max() >= n_vertices):
            raise RigError(f"{origin}: region {name!r} indexes outside 0..{n_vertices - 1}")
        regions[str(name)] = np.unique(array)
    return regions


def _obj_regions(path: Path, n_vertices: int | None) -> dict[str, np.ndarray]:
    mesh = read_obj(path)
    if n_vertices is not None and len(mesh.vertices) != n_vertices:
        raise RigError(
            f"{path}: the selection mesh has {len(mesh.vertices)} vertices, the rig {n_vertices}; "
            "export the rig's own mesh with the selections as face groups"
        )
    if not mesh.groups:
        raise RigError(f"{path}: no 'g' face groups to use as regions")
    return {name: mesh.group_vertices(name) for name in mesh.groups}
