"""`ObjSurface.text` formats only the rows that differ from the first positions it wrote, with the same
text a fresh surface writes."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from rigs._obj_surface import coordinate_lines, parse_surface

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


#: Lines a surface keeps as written around its ``v`` lines.
OTHER_LINES = st.sampled_from(["vt 0.5 0.5", "vn 0 0 1", "# comment é", "", "g head", "s off", "f 1 2 3"])


def _naive_text(surface, vertices: np.ndarray, step: float, single: bool) -> str:
    """The surface's lines with the ``v`` lines at ``vertices``, joined as the file's lines are."""
    lines = list(surface.lines)
    rows = coordinate_lines(vertices, step=step, single=single)
    for index, row, tail in zip(surface.vertex_rows.tolist(), rows, surface.vertex_tails, strict=True):
        lines[index] = row + tail
    text = "\n".join(lines)
    return text if text.endswith("\n") else text + "\n"


@settings(deadline=None, max_examples=60)
@given(
    layout=st.lists(st.one_of(st.just(None), OTHER_LINES), min_size=1, max_size=12).filter(
        lambda layout: None in layout
    ),
    tails=st.booleans(),
    trailing=st.sampled_from(["", "\n", "\n\n"]),
    step=st.sampled_from([0.0, 1e-3]),
    data=st.data(),
)
def test_every_write_is_the_surface_with_its_v_lines_replaced(layout, tails, trailing, step, data) -> None:
    """Runs of ``v`` lines anywhere among other lines, with or without tails and trailing empty lines:
    the first and every later write equal the lines joined with the ``v`` lines replaced."""
    vertex_line = "v 0 0 0 1.0" if tails else "v 0 0 0"
    text = "\n".join(vertex_line if line is None else line for line in layout) + trailing
    surface = parse_surface(text, "mesh.obj")
    n = surface.n_vertices
    positions = st.floats(-10, 10, allow_nan=False).map(lambda value: round(value, 3))
    first = np.array(data.draw(st.lists(st.tuples(positions, positions, positions), min_size=n, max_size=n)))
    assert surface.text(first, step=step) == _naive_text(surface, first, step, False)
    for _ in range(3):
        moved = data.draw(st.lists(st.integers(0, n - 1), unique=True, max_size=n))
        later = first.copy()
        later[moved] += 1.0
        expected = "# c\n" + _naive_text(surface, later, step, False)
        assert surface.text(later, step=step, comment="c") == expected
        assert surface.data(later, step=step, comment="c") == expected.encode("utf-8")
