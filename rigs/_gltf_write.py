"""Writing a rig as binary glTF 2.0 (needs pygltflib, the ``gltf`` extra)."""

from __future__ import annotations

import numpy as np

from rigs._provenance import meters_per_unit
from rigs._rig import Rig, RigError


def glb_bytes(rig: Rig, *, mesh_name: str = "face") -> bytes:
    """A binary glTF 2.0 file of ``rig``: one mesh whose morph targets are its blendshapes.

    Positions and morph-target displacements are float32 (``POSITION`` accessors with their ``min`` and
    ``max``, as glTF 2.0 sec. 3.7.2.1 requires), triangles are uint32 indices, and the shape names are
    ``mesh.extras.targetNames``, the convention :func:`load_gltf` and most tools read. glTF's unit is the
    metre: a rig in another known unit (``provenance.units``: ``cm``, ``mm``, ``in``, ...) is scaled to
    metres; one of unknown units is written as it is. The result loads back with :func:`load_gltf` to the same
    names and, up to float32 rounding and that scale, the same deltas.

    Raises
    ------
    RigError
        When pygltflib (the ``gltf`` extra) is not installed.
    """
    try:
        import pygltflib as gl
    except ImportError:
        raise RigError(
            f"{rig.provenance.label}: writing glTF needs pygltflib "
            "(pip install 'expression-packing-harness[gltf]')"
        ) from None
    scale = meters_per_unit(rig.provenance.units) or 1.0
    arrays = [np.asarray(rig.neutral * scale, dtype=np.float32)]
    arrays += [np.asarray(delta * scale, dtype=np.float32) for delta in rig.deltas]
    indices = np.asarray(rig.triangles, dtype=np.uint32).ravel()
    blob = bytearray()
    views, accessors = [], []
    for values in arrays:
        views.append(gl.BufferView(buffer=0, byteOffset=len(blob), byteLength=values.nbytes, target=34962))
        accessors.append(
            gl.Accessor(
                bufferView=len(views) - 1,
                componentType=gl.FLOAT,
                count=len(values),
                type=gl.VEC3,
                min=values.min(axis=0).tolist() if len(values) else None,
                max=values.max(axis=0).tolist() if len(values) else None,
            )
        )
        blob += values.tobytes()
    views.append(gl.BufferView(buffer=0, byteOffset=len(blob), byteLength=indices.nbytes, target=34963))
    accessors.append(
        gl.Accessor(
            bufferView=len(views) - 1, componentType=gl.UNSIGNED_INT, count=len(indices), type=gl.SCALAR
        )
    )
    blob += indices.tobytes()
    primitive = gl.Primitive(
        attributes=gl.Attributes(POSITION=0),
        indices=len(accessors) - 1,
        targets=[{"POSITION": k + 1} for k in range(rig.n_shapes)],
        mode=gl.TRIANGLES,
    )
    document = gl.GLTF2(
        asset=gl.Asset(version="2.0", generator="expression-packing-harness"),
        scene=0,
        scenes=[gl.Scene(nodes=[0])],
        nodes=[gl.Node(mesh=0, name=mesh_name)],
        meshes=[
            gl.Mesh(
                name=mesh_name,
                primitives=[primitive],
                weights=[0.0] * rig.n_shapes,
                extras={"targetNames": list(rig.names)},
            )
        ],
        accessors=accessors,
        bufferViews=views,
        buffers=[gl.Buffer(byteLength=len(blob))],
    )
    document.set_binary_blob(bytes(blob))
    return b"".join(document.save_to_bytes())
