"""Reading an OBJ holds a small multiple of the file in memory, whatever its lines: the text is read in
blocks, and what a block holds is kept in arrays, not Python objects per line."""

from __future__ import annotations

import tracemalloc
from pathlib import Path
from unittest import mock

import numpy as np
import pytest

from rigs import RigError
from rigs._arrow_lines import triangle_lines, vertex_lines
from rigs._obj import read_obj

#: Peak memory of a read, in file sizes (the file's bytes, the positions and polygons read, and a
#: block's worth of work).
LARGEST_MULTIPLE = 3.0


def _grid_obj(path: Path, n: int, *, faces: str = "f ") -> Path:
    """An OBJ of an n x n grid of vertices, two triangles a cell (``faces``: how each face line starts)."""
    rows, columns = np.divmod(np.arange(n * n), n)
    heights = np.random.default_rng(0).random(n * n).round(6)
    cells = (np.arange(n - 1)[:, None] * n + np.arange(n - 1)).ravel()
    lower, upper = [cells, cells + 1, cells + n + 1], [cells, cells + n + 1, cells + n]
    triangles = np.concatenate([np.column_stack(lower), np.column_stack(upper)])
    face_text = triangle_lines(triangles).replace(b"f ", faces.encode())
    path.write_bytes(vertex_lines(np.column_stack([rows / n, columns / n, heights])) + face_text)
    return path


def _peak_of_reading(path: Path) -> tuple[float, object]:
    """The largest memory the read of ``path`` held (Python and numpy allocations), in file sizes."""
    tracemalloc.start()
    try:
        mesh = read_obj(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    return peak / path.stat().st_size, mesh


@pytest.mark.parametrize(
    "faces",
    ["f ", pytest.param("f\t", marks=pytest.mark.slow)],  # (the tab sends every block line by line)
    ids=["plain", "line-by-line"],
)
def test_reading_an_obj_holds_a_small_multiple_of_the_file(tmp_path, faces) -> None:
    n = 700
    multiple, mesh = _peak_of_reading(_grid_obj(tmp_path / "mesh.obj", n, faces=faces))
    assert len(mesh.vertices) == n * n and len(mesh.faces) == 2 * (n - 1) ** 2
    assert mesh.faces[5].tolist() == [5, 6, n + 6]
    assert multiple <= LARGEST_MULTIPLE, f"a read held {multiple:.1f} times the file"


def test_a_read_that_runs_out_of_memory_is_one_line_naming_the_file(tmp_path) -> None:
    path = _grid_obj(tmp_path / "flood.obj", 20)
    with mock.patch("rigs._obj._Reader.read", side_effect=MemoryError), pytest.raises(RigError) as caught:
        read_obj(path)
    assert str(caught.value).startswith(f"{path}: too large to read in the memory available")
    assert "\n" not in str(caught.value)
