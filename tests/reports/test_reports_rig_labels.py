"""Rig names in reports: short, and distinct when rig files share a stem (``a/face.npz``, ``b/face.npz``)."""

from __future__ import annotations

import shutil

from registry import claim
from registry._outdir import MANIFEST_NAME
from reports import build_report
from reports._tables import rig_label, rig_labels


def test_rig_labels_are_short_and_distinct() -> None:
    labels = rig_labels(
        ["female", "takes/female.npz", "a/face.npz", "b/face.npz", "p/x/head", "q/x/head", "c/solo.glb"]
    )
    assert labels == {
        "female": "female",
        "takes/female.npz": "takes/female",
        "a/face.npz": "a/face",
        "b/face.npz": "b/face",
        "p/x/head": "p/x/head",
        "q/x/head": "q/x/head",
        "c/solo.glb": "solo",
    }
    assert rig_labels(["s/face.npz", "s/face.glb"]) == {
        "s/face.npz": "s/face.npz",
        "s/face.glb": "s/face.glb",
    }
    assert rig_label("faces/actor.npz") == "actor"
    assert rig_label("a/face.npz", ["b/face.npz"]) == "a/face"


def test_a_report_on_two_rig_files_with_one_stem_keeps_them_apart(fabricate, face_rig_file, tmp_path) -> None:
    paths = []
    for folder in ("a", "b"):
        (tmp_path / folder).mkdir()
        paths.append(shutil.copy(face_rig_file, tmp_path / folder / "face.npz"))
    run = fabricate(tmp_path / "run", rig=str(paths[0]))
    other = fabricate(tmp_path / "other", rig=str(paths[1]))
    for part in (other / "records").glob("*.parquet"):
        shutil.copy(part, run / "records" / part.name)

    _, text = build_report(run)
    markdown = text.read_text()
    for label in ("a/face", "b/face"):
        assert f"| {label} | alien | cpsat |" in markdown
        assert f"Shapes covered against the number of expressions on {label}." in markdown
    figures = sorted(path.name for path in (text.parent / "figures").glob("coverage-*.png"))
    assert figures == ["coverage-a-face.png", "coverage-b-face.png"]


def test_a_rebuilt_report_drops_figures_it_no_longer_has(make_run) -> None:
    run = make_run("run")
    _, text = build_report(run)
    stale = text.parent / "figures" / "coverage-renamed-rig.png"
    earlier = {
        path.relative_to(text.parent).as_posix(): path.read_bytes()
        for path in text.parent.rglob("*")
        if path.is_file() and path.name != MANIFEST_NAME
    }
    with claim(text.parent, kind="report", force=True) as folder:  # a report of the rig's earlier name
        folder.replace({**earlier, "figures/coverage-renamed-rig.png": b"old"})
    assert stale.exists()
    build_report(run)
    assert not stale.exists()
    assert any((text.parent / "figures").glob("coverage-*.png"))
