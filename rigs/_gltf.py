"""glTF 2.0 (``.gltf`` / ``.glb``) morph targets as a rig.

One mesh becomes the rig: its primitive's ``POSITION`` is the neutral and each morph target's ``POSITION``
is a blendshape delta (glTF morph targets are already displacements). Exporters write one primitive per
material (skin, teeth, eyelashes), all with the same morph targets; such primitives are read as one mesh.
Target names come from ``primitive.extras.targetNames`` when present, else ``mesh.extras.targetNames``
(the de-facto convention of Blender and most exporters), else ``target_<i>``. What the mesh holds besides
positions, its texture coordinates (``TEXCOORD_0``), normals (``NORMAL``) and each primitive's material, is
kept as the rig's ``surface`` (`rigs.Surface` of a `rigs._gltf_surface.GltfSurface`), so that the rig can be
written out with them. Every other mesh (eyes, teeth) is named in a `RigWarning`.

The file is untrusted: the document and its node hierarchy are read with every field checked
(:mod:`rigs._gltf_document`), buffers only from the GLB binary chunk, valid ``data:`` URIs or regular files
inside the glTF's folder, each accessor sized against the bytes its buffer view really holds before anything
is allocated (:mod:`rigs._gltf_buffers`), and all morph targets together against what the files can
describe (:func:`rigs._safe.check_budget`).
"""

from __future__ import annotations

import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

from rigs._gltf_appearance import appearance, surface_of
from rigs._gltf_buffers import Buffers
from rigs._gltf_document import (
    COMPRESSIONS,
    INDEX_TYPES,
    Document,
    check_extensions,
    is_int,
    node_parents,
    open_gltf,
    world_matrix,
)
from rigs._gltf_weld import collapsed, weld_seams
from rigs._provenance import Provenance, Surface, Weld
from rigs._rig import Rig, RigError, RigWarning
from rigs._safe import check_budget

_MODES = {
    0: "POINTS",
    1: "LINES",
    2: "LINE_LOOP",
    3: "LINE_STRIP",
    4: "TRIANGLES",
    5: "TRIANGLE_STRIP",
    6: "TRIANGLE_FAN",
}


def load_gltf(
    path: str | Path,
    *,
    mesh: str | int | None = None,
    primitive: int | None = None,
    weld: bool = False,
    weld_tolerance: float = 1e-6,
    transform: bool = True,
) -> Rig:
    """A rig from the morph targets of one glTF 2.0 mesh (its primitives with the same targets).

    Parameters
    ----------
    path : path
        A ``.gltf`` (buffers as files in its folder or as data URIs) or ``.glb`` file.
    mesh : str or int, optional
        Name or index of the mesh; default: the primitive with the most morph targets in the file
        (ties: more vertices, then file order). The other meshes (eyes, teeth, ...) are named in a
        `RigWarning`, with their morph target counts.
    primitive : int, optional
        Index of the one primitive to read within the chosen mesh; default: its primitive with the most
        targets, together with every other triangle primitive of the mesh (one primitive per material,
        as exporters write them), vertices in primitive order. Those must have the same morph targets
        (count and names), as glTF requires; primitives of points or lines are left out with a
        `RigWarning`.
    weld : bool
        Merge vertices that exporters split along UV or normal seams: vertices closer than
        ``weld_tolerance`` whose displacements also agree within it in every target become one.
    weld_tolerance : float
        Relative to the neutral's bounding-box diagonal.
    transform : bool
        Apply the world transform of the first node that instances the mesh (so positions are what the
        scene shows; this also dequantises ``KHR_mesh_quantization`` data). Skinned meshes are left in
        mesh space, as the glTF specification says.

    Returns
    -------
    Rig whose ``provenance`` (`rigs.Provenance`) says ``units = "m"`` (glTF's unit), ``format = "gltf"``,
    ``single`` (float32 coordinates),
    the ``mesh`` and the ``primitives`` read, the ``transform`` applied and, after welding, the ``weld``
    (`rigs.Weld`: the count merged and the rig vertex of each glTF vertex); its ``surface`` holds a
    `GltfSurface` when a primitive has texture coordinates, normals or a material.

    Raises
    ------
    RigError
        One line naming the file (the mesh, primitive and target where there is one) and the problem:
        not a regular file, not glTF 2.0 (or a malformed GLB container), a field of the wrong type or
        out of range, no morph targets, unknown mesh, a compressed primitive (naming the extension and
        how to decode it), another required extension it does not implement, a buffer URI that is
        absolute, leaves the folder, names a scheme or is a malformed ``data:`` URI, a missing buffer,
        an accessor of the wrong type, past the end of its buffer view, or with a ``byteStride``
        smaller than its elements, index accessors that are not unsigned integers, sibling primitives
        with other morph targets, duplicate target names, a cycle in the node hierarchy, or arrays
        larger than the file can describe.

    Warns
    -----
    RigWarning
        Naming every other mesh, with its morph target count, when ``mesh`` is not given (only one is
        read), the primitives of points or lines left out of the mesh, and texture coordinates, normals
        or materials left out because they are malformed (the positions are read all the same).
    """
    path = Path(path)
    source = str(path)
    document, blob, size = open_gltf(path)
    check_extensions(document, source)
    mesh_index, primitive_index = _choose(document, mesh, primitive, source)
    chosen_mesh = document.items("meshes")[mesh_index]
    primitives = document.field(chosen_mesh, "primitives", list, _label(source, chosen_mesh, mesh_index))
    chosen = primitives[primitive_index]
    label = _primitive_label(source, chosen_mesh, mesh_index, primitive_index)
    names = _target_names(document, chosen_mesh, chosen, len(_targets(document, chosen, label)), label)
    if primitive is not None:
        members = [primitive_index]
    else:
        members = _same_targets(document, chosen_mesh, mesh_index, primitive_index, names, source)
    if mesh is None:
        _warn_other_meshes(document, mesh_index, source)
    buffers = Buffers(document, path, blob, size)
    labels = [_primitive_label(source, chosen_mesh, mesh_index, j) for j in members]
    counts = [_vertex_count(document, primitives[j], label) for j, label in zip(members, labels, strict=True)]
    for j, label in zip(members, labels, strict=True):
        buffers.load_for(_primitive_accessors(document, primitives[j], label), label)
    check_budget(
        source,
        f"{len(names)} morph targets of {sum(counts)} vertices",
        len(names) * sum(counts) * 3 * 8,
        buffers.source_bytes,
    )
    parts = [
        _read_primitive(document, buffers, primitives[j], label, count)
        for j, label, count in zip(members, labels, counts, strict=True)
    ]
    # Primitives of one vertex set (the same POSITION, target, TEXCOORD_0 and NORMAL accessors: one index
    # buffer per material) share their vertices: each set is read once, and their triangles index it.
    keys = [_vertex_key(document, primitives[j], label) for j, label in zip(members, labels, strict=True)]
    owner = [keys.index(key) for key in keys]  # (the first primitive of each set)
    blocks = sorted(set(owner))
    starts = dict(zip(blocks, np.cumsum([0, *[counts[b] for b in blocks[:-1]]]).tolist(), strict=True))
    neutral = np.concatenate([parts[b][0] for b in blocks])
    deltas = np.concatenate([parts[b][1] for b in blocks], axis=1)
    triangles = np.concatenate([part[2] + starts[first] for part, first in zip(parts, owner, strict=True)])
    looks = [
        appearance(document, buffers, primitives[j], label, count)
        for j, label, count in zip(members, labels, counts, strict=True)
    ]

    provenance = Provenance(
        source=source,
        format="gltf",
        units="m",
        mesh=str(chosen_mesh.get("name") or mesh_index),
        primitives=tuple(members),
        single=True,
    )
    surface = surface_of(
        document,
        [looks[b][:2] for b in blocks],
        [counts[b] for b in blocks],
        [look[2] for look in looks],
        [len(part[2]) for part in parts],
        triangles,
    )
    parents = node_parents(document, source)
    if transform:
        matrix, node_name = world_matrix(document, parents, mesh_index, source)
        if matrix is not None:
            with np.errstate(over="ignore", invalid="ignore"):  # (overflowing positions: `Rig` refuses them)
                neutral = neutral @ matrix[:3, :3].T + matrix[:3, 3]
                deltas = deltas @ matrix[:3, :3].T
            provenance = replace(provenance, transform=f"world matrix of node {node_name!r}")
            if surface is not None:
                surface = surface.transformed(matrix[:3, :3])
    if weld:
        corners = triangles
        neutral, deltas, triangles, vertex_map = weld_seams(neutral, deltas, triangles, weld_tolerance)
        provenance = replace(provenance, weld=Weld(int(len(vertex_map) - len(neutral)), vertex_map))
        if surface is not None:
            surface = surface.welded(vertex_map, ~collapsed(vertex_map[corners]))
    return Rig(
        neutral=neutral,
        deltas=deltas,
        triangles=triangles,
        names=names,
        provenance=provenance,
        surface=None if surface is None else Surface(gltf=surface),
    )


def _label(source: str, mesh: dict, mesh_index: int) -> str:
    return f"{source}: mesh {mesh.get('name') or mesh_index!r:.80}"


def _primitive_label(source: str, mesh: dict, mesh_index: int, primitive_index: int) -> str:
    return f"{_label(source, mesh, mesh_index)} primitive {primitive_index}"


def _attributes(document: Document, holder: dict, key: str, label: str) -> dict:
    attributes = document.field(holder, key, dict, label, default={})
    return attributes


def _targets(document: Document, primitive: dict, label: str) -> list[dict]:
    targets = document.field(primitive, "targets", list, label, default=[])
    if not all(isinstance(target, dict) for target in targets):
        raise RigError(f"{label}: every morph target must be an object of attributes")
    return targets


def _mode(document: Document, primitive: dict, label: str) -> int:
    return document.field(primitive, "mode", int, label, default=4)


def _position_count(document: Document, primitive: dict) -> int:
    """The POSITION accessor's count when it is well formed, else 0 (for ranking primitives only)."""
    attributes = primitive.get("attributes")
    index = attributes.get("POSITION") if isinstance(attributes, dict) else None
    accessors = document.content.get("accessors")
    if not is_int(index) or not isinstance(accessors, list) or not 0 <= index < len(accessors):
        return 0
    count = accessors[index].get("count") if isinstance(accessors[index], dict) else None
    return count if is_int(count) and count > 0 else 0


def _choose(
    document: Document, mesh: str | int | None, primitive: int | None, source: str
) -> tuple[int, int]:
    meshes = document.items("meshes")
    if not meshes:
        raise RigError(f"{source}: has no meshes")
    if mesh is None:
        candidates = range(len(meshes))
    elif is_int(mesh):
        if not 0 <= mesh < len(meshes):
            raise RigError(f"{source}: no mesh {mesh} (the file has {len(meshes)})")
        candidates = [mesh]
    else:
        candidates = [i for i, m in enumerate(meshes) if m.get("name") == mesh]
        if not candidates:
            available = ", ".join(repr(m.get("name")) for m in meshes[:8])
            raise RigError(f"{source}: no mesh named {mesh!r} (meshes: {available})")
    options = []
    for i in candidates:
        primitives = document.field(meshes[i], "primitives", list, _label(source, meshes[i], i), default=[])
        if primitive is not None:
            if not 0 <= primitive < len(primitives):
                if mesh is None:
                    continue
                raise RigError(f"{_label(source, meshes[i], i)} has no primitive {primitive}")
            indices = [primitive]
        else:
            indices = range(len(primitives))
        for j in indices:
            p = primitives[j]
            if not isinstance(p, dict):
                raise RigError(f"{_primitive_label(source, meshes[i], i, j)}: is not an object")
            targets = _targets(document, p, _primitive_label(source, meshes[i], i, j))
            options.append((len(targets), _position_count(document, p), -i, -j))
    if not options:
        raise RigError(f"{source}: the chosen mesh has no primitives")
    best = max(options)
    if best[0] == 0:
        raise RigError(f"{source}: no mesh primitive has morph targets")
    return -best[2], -best[3]


def _same_targets(
    document: Document, mesh: dict, mesh_index: int, chosen: int, names: tuple[str, ...], source: str
) -> list[int]:
    """The triangle primitives of ``mesh``, which must have the chosen one's morph targets (count and names).

    Primitives of points or lines are left out with a `RigWarning`.
    """
    primitives = mesh["primitives"]
    count = len(names)
    members = []
    for j, other in enumerate(primitives):
        label = _primitive_label(source, mesh, mesh_index, j)
        if j == chosen:
            members.append(j)
            continue
        mode = _mode(document, other, label)
        if mode not in (4, 5, 6):
            warnings.warn(
                f"{label}: mode {mode} ({_MODES.get(mode, 'unknown')}) has no triangles; left out",
                RigWarning,
                stacklevel=4,
            )
            continue
        theirs = len(_targets(document, other, label))
        if theirs != count:
            raise RigError(
                f"{label}: has {theirs} morph targets, primitive {chosen} has {count} (glTF gives every "
                "primitive of a mesh the same targets); read one primitive with primitive=N "
                "(harness rigs convert --primitive N)"
            )
        if _target_names(document, mesh, other, count, label) != names:
            raise RigError(
                f"{label}: its morph targets are named differently from those of primitive {chosen}; "
                "read one primitive with primitive=N (harness rigs convert --primitive N)"
            )
        members.append(j)
    return members


def _warn_other_meshes(document: Document, chosen: int, source: str) -> None:
    """Name every mesh but the one read (eyes, teeth, a tongue with its own morph targets) in one
    `RigWarning`, so that none is left out unsaid."""
    left_out = []
    for i, mesh in enumerate(document.items("meshes")):
        primitives = mesh.get("primitives")
        if i == chosen:
            continue
        counts = [
            len(p["targets"])
            for p in (primitives if isinstance(primitives, list) else [])
            if isinstance(p, dict) and isinstance(p.get("targets"), list)
        ]
        most = max(counts, default=0)
        held = f"{most} morph target{'s' if most > 1 else ''}" if most else "no morph targets"
        left_out.append(f"{mesh.get('name') or i!r:.80} ({held})")
    if left_out:
        warnings.warn(
            f"{source}: only one mesh is read; left out: {', '.join(left_out)} "
            "(read another with mesh=NAME: harness rigs convert --mesh NAME)",
            RigWarning,
            stacklevel=4,
        )


def _target_names(document: Document, mesh: dict, primitive: dict, count: int, label: str) -> tuple[str, ...]:
    names = None
    for holder in (primitive, mesh):
        extras = holder.get("extras")
        if isinstance(extras, dict) and extras.get("targetNames") is not None:
            names = extras["targetNames"]
            break
    if names is None:
        return tuple(f"target_{k}" for k in range(count))
    if not isinstance(names, list) or len(names) != count:
        size = len(names) if isinstance(names, list) else names
        raise RigError(f"{label}: extras.targetNames has {size!r:.40} names for {count} morph targets")
    seen: set[str] = set()
    for name in names:
        if not isinstance(name, str):
            raise RigError(f"{label}: extras.targetNames holds {name!r:.40}, not a name")
        if name in seen:
            raise RigError(f"{label}: duplicate morph target name {name!r} in extras.targetNames")
        seen.add(name)
    return tuple(names)


def _vertex_key(document: Document, primitive: dict, label: str) -> tuple:
    """What a primitive's vertices are read from: its POSITION, target POSITION, TEXCOORD_0 and NORMAL
    accessors (two primitives with equal keys have the same vertices)."""
    attributes = _attributes(document, primitive, "attributes", label)
    targets = tuple(target.get("POSITION") for target in _targets(document, primitive, label))
    return (
        _position_index(document, primitive, label),
        targets,
        attributes.get("TEXCOORD_0"),
        attributes.get("NORMAL"),
    )


def _position_index(document: Document, primitive: dict, label: str) -> int:
    index = _attributes(document, primitive, "attributes", label).get("POSITION")
    if index is None:
        raise RigError(f"{label}: has no POSITION attribute")
    return index


def _vertex_count(document: Document, primitive: dict, label: str) -> int:
    """The number of vertices of ``primitive``: its POSITION accessor's count, which must be stored data."""
    position = _position_index(document, primitive, label)
    accessor = document.item("accessors", position, f"{label} POSITION")
    draco = "KHR_draco_mesh_compression"
    extensions = primitive.get("extensions")
    if isinstance(extensions, dict) and draco in extensions and accessor.get("bufferView") is None:
        raise RigError(f"{label}: compressed with {draco} ({COMPRESSIONS[draco]})")
    if accessor.get("bufferView") is None:
        raise RigError(
            f"{label} POSITION: accessor {position} has no bufferView; the neutral positions must be stored"
        )
    return document.count(accessor, "count", f"{label} POSITION: accessor {position}")


def _primitive_accessors(document: Document, primitive: dict, label: str) -> list[int]:
    """The accessors the reader will decode for ``primitive``: positions, target positions, indices."""
    accessors = [_position_index(document, primitive, label)]
    for k, target in enumerate(_targets(document, primitive, label)):
        if target.get("POSITION") is not None:
            accessors.append(target["POSITION"])
        elif not all(is_int(value) for value in target.values()):
            raise RigError(f"{label}: target {k} has an attribute that is not an accessor index")
    if primitive.get("indices") is not None:
        accessors.append(primitive["indices"])
    return accessors


def _read_primitive(
    document: Document, buffers: Buffers, primitive: dict, label: str, n_vertices: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Neutral positions, target deltas and triangles of one primitive."""
    position = _position_index(document, primitive, label)
    neutral = buffers.accessor(position, "VEC3", f"{label} POSITION", count=n_vertices)
    targets = _targets(document, primitive, label)
    deltas = np.zeros((len(targets), n_vertices, 3))
    for k, target in enumerate(targets):
        index = target.get("POSITION")
        if index is None:
            continue
        accessor = document.item("accessors", index, f"{label} target {k} POSITION")
        elements = document.count(accessor, "count", f"{label} target {k} POSITION: accessor {index}")
        if elements != n_vertices:
            raise RigError(f"{label}: target {k} has {elements} positions for {n_vertices} vertices")
        deltas[k] = buffers.accessor(index, "VEC3", f"{label} target {k} POSITION", count=n_vertices)
    return neutral, deltas, _triangles(document, buffers, primitive, n_vertices, label)


def _triangles(
    document: Document, buffers: Buffers, primitive: dict, n_vertices: int, label: str
) -> np.ndarray:
    mode = _mode(document, primitive, label)
    if mode not in (4, 5, 6):
        raise RigError(f"{label}: mode {mode} ({_MODES.get(mode, 'unknown')}) has no triangles")
    if primitive.get("indices") is None:
        corners = np.arange(n_vertices, dtype=np.int64)
    else:
        corners = buffers.accessor(
            primitive["indices"], "SCALAR", f"{label} indices", components=INDEX_TYPES
        ).astype(np.int64)
    if corners.size and corners.max() >= n_vertices:
        raise RigError(f"{label}: index {int(corners.max())} is past the {n_vertices} vertices")
    if mode == 4:
        if corners.size % 3:
            raise RigError(f"{label}: {corners.size} triangle indices is not a multiple of 3")
        return corners.reshape(-1, 3)
    if corners.size < 3:
        return np.zeros((0, 3), dtype=np.int64)
    steps = np.arange(corners.size - 2)
    if mode == 5:
        odd = steps % 2 == 1
        first = np.where(odd, corners[steps + 1], corners[steps])
        second = np.where(odd, corners[steps], corners[steps + 1])
        return np.stack([first, second, corners[steps + 2]], axis=1)
    return np.stack([np.full(steps.size, corners[0]), corners[steps + 1], corners[steps + 2]], axis=1)
