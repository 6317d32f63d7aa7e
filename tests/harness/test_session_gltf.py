"""``harness pack`` of a glTF rig: coordinates at float32's precision whatever the node's transform made of
them, and what the reader warned said once."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

import rigs
from harness.cli import main
from tests.harness.test_session_pack import invoke, lines_of

gl = pytest.importorskip("pygltflib")


def glb(tmp_path: Path, *, turned: bool = False, eyes: bool = False) -> Path:
    """The generated ARKit rig as a GLB: its node turned 45 degrees about the vertical (a transform the
    reader applies), and with a second mesh (``eyes``) that is not read."""
    rig = rigs.generate("arkit52")
    path = tmp_path / "face.glb"
    path.write_bytes(rigs.glb_bytes(rig, mesh_name="face"))
    document = gl.GLTF2().load(str(path))
    if turned:
        document.nodes[0].rotation = [0.0, 0.3826834, 0.0, 0.9238795]
    if eyes:
        mesh = copy.deepcopy(document.meshes[0])
        mesh.name, mesh.extras = "eyes", {"targetNames": ["lookLeft", "lookRight"]}
        mesh.primitives[0].targets, mesh.weights = mesh.primitives[0].targets[:2], [0.0, 0.0]
        document.meshes.append(mesh)
        document.nodes.append(gl.Node(mesh=1, name="eyes"))
        document.scenes[0].nodes.append(1)
    document.save(str(path))
    return path


def digits(text: str) -> str:
    """The significant digits of a number's text."""
    mantissa = text.lower().partition("e")[0]
    return mantissa.lstrip("-").replace(".", "").lstrip("0").rstrip("0")


def test_a_turned_gltf_is_written_at_float32_precision(tmp_path) -> None:
    out = tmp_path / "session"
    result = invoke("pack", glb(tmp_path, turned=True), "--no-pictures", "--jmax", "2", "--out", out)
    assert result.exit_code == 0, result.output
    for name in ("neutral.obj", "expression_01.obj"):
        values = [value for line in lines_of(out / name, "v") for value in line.split()[1:4]]
        assert all(digits(value) == digits(str(np.float32(value))) for value in values)  # float32's shortest
        assert max(len(digits(value)) for value in values) <= 9


def test_what_the_gltf_reader_warned_is_said_once(tmp_path, capsys) -> None:
    out = tmp_path / "session"
    with pytest.raises(SystemExit) as ended:  # the command as run: its warnings shown as they come
        main(["pack", str(glb(tmp_path, eyes=True)), "--no-pictures", "--jmax", "2", "--out", str(out)])
    assert ended.value.code == 0
    said = " ".join(" ".join(capsys.readouterr()).split())
    assert said.count("only one mesh is read; left out: 'eyes'") == 1, said
    assert (out / "session.html").read_text().count("left out: &#x27;eyes&#x27;") == 1
