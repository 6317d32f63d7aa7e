"""`rigs.load` of a folder of OBJs reads the blendshape files in order and names the first bad one."""

from __future__ import annotations

import numpy as np
import pytest

import rigs
from rigs import RigError


@pytest.fixture
def folder(tmp_path):
    rig = rigs.generate(rigs.PRESETS["tiny"], seed=3)
    return rigs.save(rig, tmp_path / "rig"), rig


def test_the_folder_reads_back_as_saved(folder) -> None:
    path, rig = folder
    read = rigs.load(path)
    assert read.names == rig.names
    assert np.allclose(read.deltas, rig.deltas, atol=1e-5 * rig.diagonal())  # (up to the noise floor)


def test_the_first_bad_file_in_order_is_named(folder) -> None:
    path, rig = folder
    first, later = rig.names[2], rig.names[-2]
    for name in (later, first):  # (the later file spoilt too: it must not be named)
        shape = path / f"{name}.obj"
        shape.write_text(shape.read_text().replace("\nv ", "\nv oops ", 1))
    with pytest.raises(RigError, match=f"{first}.obj:"):
        rigs.load(path)
