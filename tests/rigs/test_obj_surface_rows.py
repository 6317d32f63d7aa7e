"""`ObjSurface.text` formats only the rows that differ from the first positions it wrote, with the same
text a fresh surface writes."""

from __future__ import annotations

import numpy as np
import pytest

from rigs._obj import parse_surface

TEXT = "# mesh\nv 0 0 0\nvt 0 0\nv 1 0 0 1.0\nv 0 1 0\nv 1 1 0\nf 1/1 2/1 3/1\nf 2/1 4/1 3/1\n"


@pytest.mark.parametrize(("step", "single"), [(0.0, False), (1e-4, False), (0.0, True)])
def test_later_positions_read_as_a_fresh_surface_writes_them(step, single) -> None:
    rng = np.random.default_rng(0)
    first = rng.normal(size=(4, 3))
    surface = parse_surface(TEXT, "mesh.obj")
    surface.text(first, step=step, single=single)
    for moved in ([0], [1, 3], [], [0, 1, 2, 3]):
        later = first.copy()
        later[moved] += rng.normal(size=(len(moved), 3))
        expected = parse_surface(TEXT, "mesh.obj").text(later, step=step, single=single, comment="c")
        assert surface.text(later, step=step, single=single, comment="c") == expected


def test_a_signed_zero_is_a_change() -> None:
    surface = parse_surface(TEXT, "mesh.obj")
    first = np.zeros((4, 3))
    surface.text(first)
    flipped = first.copy()
    flipped[2, 1] = -0.0
    assert "v 0 -0 0" in surface.text(flipped)
    assert surface.text(flipped) == parse_surface(TEXT, "mesh.obj").text(flipped)
