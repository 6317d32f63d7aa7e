"""`rigs.load` of a folder of OBJs reads several blendshape files at once and gives what one reader gives."""

from __future__ import annotations

import numpy as np
import pytest

import rigs
from rigs import RigError
from rigs import _obj_folder as obj


@pytest.fixture
def folder(tmp_path):
    rig = rigs.generate(rigs.PRESETS["tiny"], seed=3)
    return rigs.save(rig, tmp_path / "rig"), rig


def test_the_rig_is_the_same_read_by_one_reader_or_several(folder, monkeypatch) -> None:
    path, rig = folder
    several = rigs.load(path)
    monkeypatch.setattr(obj, "_READERS", 1)
    one = rigs.load(path)
    assert several.names == one.names == rig.names
    assert np.array_equal(several.deltas, one.deltas) and np.array_equal(several.neutral, one.neutral)
    assert np.allclose(several.deltas, rig.deltas, atol=1e-5 * rig.diagonal())  # (up to the noise floor)


@pytest.mark.parametrize("readers", [1, 4])
def test_the_first_bad_file_in_order_is_named(folder, monkeypatch, readers) -> None:
    path, rig = folder
    monkeypatch.setattr(obj, "_READERS", readers)
    first, later = rig.names[2], rig.names[-2]
    for name in (later, first):  # (the later file spoilt too: it must not be named)
        shape = path / f"{name}.obj"
        shape.write_text(shape.read_text().replace("\nv ", "\nv oops ", 1))
    with pytest.raises(RigError, match=f"{first}.obj:"):
        rigs.load(path)
