"""USD rigs (UsdSkel BlendShape offsets and pointIndices): a round trip keeps names and deltas."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import rigs
from rigs import RigError, RigWarning

pytest.importorskip("pxr", reason="usd-core is not installed (pip install 'expression-packing-harness[usd]')")


@pytest.mark.parametrize("suffix", [".usda", ".usdc", ".usd"])
def test_round_trip_keeps_names_deltas_and_triangles(tmp_path, suffix):
    rig = rigs.generate("tiny")
    loaded = rigs.load(rigs.save(rig, tmp_path / f"rig{suffix}"), noise_floor=0.0)
    assert loaded.names == rig.names and loaded.provenance.format == "usd"
    assert np.abs(loaded.deltas - rig.deltas).max() < 1e-6 * rig.diagonal()  # float32, as the schema stores
    assert np.abs(loaded.neutral - rig.neutral).max() < 1e-6 * rig.diagonal()
    assert np.array_equal(loaded.triangles, rig.triangles)


def test_sparse_offsets_and_units_survive(tmp_path, faceunits):
    path = rigs.save(faceunits, tmp_path / "faceunits.usdc")
    loaded = rigs.load(path, noise_floor=0.0)
    assert loaded.names == faceunits.names and loaded.provenance.units == "dm"
    assert np.abs(loaded.deltas - faceunits.deltas).max() < 1e-6
    from pxr import Usd, UsdSkel

    stage = Usd.Stage.Open(str(path))
    shape = UsdSkel.BlendShape(stage.GetPrimAtPath("/Rig/Face/jawOpen"))
    moved = np.flatnonzero(np.any(faceunits.deltas[faceunits.index("jawOpen")] != 0, axis=1))
    assert list(shape.GetPointIndicesAttr().Get()) == moved.tolist()  # only the moved points are stored


def test_a_layer_outside_the_folder_is_refused(tmp_path):
    rig = rigs.generate("tiny")
    outside = rigs.save(rig, tmp_path / "outside.usda")
    folder = tmp_path / "rig"
    folder.mkdir()
    (folder / "face.usda").write_text(f"#usda 1.0\n(\n    subLayers = [@{outside}@]\n)\n")
    with pytest.raises(RigError, match=r"face\.usda"):
        rigs.load(folder / "face.usda")


def test_bad_point_indices_are_one_line_errors(tmp_path):
    from pxr import Usd, UsdSkel, Vt

    path = rigs.save(rigs.generate("tiny"), tmp_path / "rig.usda")
    stage = Usd.Stage.Open(str(path))
    shape = UsdSkel.BlendShape(stage.GetPrimAtPath("/Rig/Face/jawOpen"))
    shape.GetPointIndicesAttr().Set(Vt.IntArray([0, 10**6]))
    stage.GetRootLayer().Save()
    with pytest.raises(RigError, match=r"rig\.usda: mesh /Rig/Face blend shape /Rig/Face/jawOpen: "):
        rigs.load(path)


def test_without_skel_blend_shapes_names_the_target_prims_name_the_shapes(tmp_path):
    """``skel:blendShapes`` is optional in UsdSkel: without it every target is named by its prim."""
    from pxr import Usd, UsdSkel

    rig = rigs.generate("tiny")
    path = rigs.save(rig, tmp_path / "rig.usda")
    stage = Usd.Stage.Open(str(path))
    UsdSkel.BindingAPI(stage.GetPrimAtPath("/Rig/Face")).GetBlendShapesAttr().Clear()
    stage.GetRootLayer().Save()
    loaded = rigs.load(path, noise_floor=0.0)
    assert loaded.names == rig.names
    assert np.abs(loaded.deltas - rig.deltas).max() < 1e-6 * rig.diagonal()


def _edited(tmp_path, edit) -> Path:
    """The tiny rig as USD, changed by ``edit(stage)``."""
    from pxr import Usd

    path = rigs.save(rigs.generate("tiny"), tmp_path / "rig.usda")
    stage = Usd.Stage.Open(str(path))
    edit(stage)
    stage.GetRootLayer().Save()
    return path


def test_time_sampled_points_and_an_unapplied_binding_say_what_is_wrong(tmp_path):
    from pxr import UsdGeom, UsdSkel

    def sampled(stage):
        points = UsdGeom.Mesh(stage.GetPrimAtPath("/Rig/Face")).GetPointsAttr()
        rest = points.Get()
        points.Clear()
        points.Set(rest, 1.0)
        points.Set(rest, 2.0)

    with pytest.raises(
        RigError, match=r"mesh /Rig/Face: its points have no default value, only 2 time samples"
    ):
        rigs.load(_edited(tmp_path / "a", sampled))

    def unapplied(stage):
        stage.GetPrimAtPath("/Rig/Face").RemoveAPI(UsdSkel.BindingAPI)

    with pytest.raises(
        RigError, match=r"mesh /Rig/Face has skel:blendShapeTargets but does not apply the Skel"
    ):
        rigs.load(_edited(tmp_path / "b", unapplied))


def _add_bound_eye(stage):
    """A second mesh, /Rig/Eye, of one triangle bound to one blend shape ("blink")."""
    from pxr import UsdGeom, UsdSkel

    eye = UsdGeom.Mesh.Define(stage, "/Rig/Eye")
    eye.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0)])
    eye.CreateFaceVertexCountsAttr([3])
    eye.CreateFaceVertexIndicesAttr([0, 1, 2])
    blink = UsdSkel.BlendShape.Define(stage, "/Rig/Eye/blink")
    blink.CreateOffsetsAttr([(0, 0, 0.1), (0, 0, 0), (0, 0, 0)])
    UsdSkel.BindingAPI.Apply(eye.GetPrim()).CreateBlendShapeTargetsRel().SetTargets([blink.GetPath()])


def test_every_mesh_left_out_is_named(tmp_path):
    path = _edited(tmp_path, _add_bound_eye)
    with pytest.warns(RigWarning, match=r"only one mesh is read; left out: /Rig/Eye \(1 blend shape\)"):
        assert rigs.load(path).names == rigs.generate("tiny").names
    assert rigs.load(path, mesh="/Rig/Eye").names == ("blink",)


@pytest.mark.parametrize(("units", "read"), [(None, "unknown"), ("in", "in"), ("mm", "mm")])
def test_a_length_unit_round_trips_even_unknown(tmp_path, units, read):
    """A stage without metersPerUnit is in centimetres by USD's rule, so a rig of unknown units says so
    in its layer's custom data rather than come back as centimetres (and a glTF written from it scaled)."""
    from dataclasses import replace

    rig = replace(rigs.generate("tiny"), provenance=rigs.Provenance(units=units))
    assert rigs.load(rigs.save(rig, tmp_path / "rig.usda")).provenance.units == read


def test_an_unbound_mesh_beside_a_bound_one_is_named_as_left_out(tmp_path):
    from pxr import UsdSkel

    def unbound_face_and_bound_eye(stage):
        stage.GetPrimAtPath("/Rig/Face").RemoveAPI(UsdSkel.BindingAPI)
        _add_bound_eye(stage)

    path = _edited(tmp_path, unbound_face_and_bound_eye)
    with pytest.warns(RigWarning, match=r"/Rig/Face \(skel:blendShapeTargets without the SkelBindingAPI\)"):
        rigs.load(path)
