"""`rigs._arrow_lines`: every coordinate written reads back as the same float, in its shortest text, and
the reader reads it back without pandas."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
from hypothesis import given, settings, strategies as st
from hypothesis.extra import numpy as hnp

from rigs._arrow_lines import read_vertex_lines, triangle_lines, vertex_lines

FINITE64 = st.floats(allow_nan=False, allow_infinity=False)
FINITE32 = st.floats(allow_nan=False, allow_infinity=False, width=32)


def _significant(text: str) -> int:
    """Number of significant digits of a decimal number's text."""
    mantissa = text.lower().lstrip("-").split("e")[0].replace(".", "")
    return len(mantissa.strip("0")) or 1


def _read(text: str) -> list[list[str]]:
    lines = text.split("\n")
    assert lines[-1] == ""  # every line ends in a line feed
    return [line.split(" ") for line in lines[:-1]]


@settings(deadline=None)  # (the first example imports Arrow)
@given(hnp.arrays(np.float64, st.tuples(st.integers(0, 20), st.just(3)), elements=FINITE64))
def test_float64_coordinates_read_back_bit_for_bit_with_the_fewest_digits(vertices: np.ndarray) -> None:
    rows = _read(vertex_lines(vertices).decode("ascii"))
    assert len(rows) == len(vertices)
    for words, vertex in zip(rows, vertices.tolist(), strict=True):
        assert words[0] == "v" and len(words) == 4
        read = np.array([float(word) for word in words[1:]])
        assert read.view(np.int64).tolist() == np.array(vertex).view(np.int64).tolist()  # (-0.0 kept)
        assert [_significant(word) for word in words[1:]] == [_significant(repr(value)) for value in vertex]


@settings(deadline=None)  # (the first example imports Arrow)
@given(hnp.arrays(np.float32, st.tuples(st.integers(1, 20), st.just(3)), elements=FINITE32))
def test_single_precision_coordinates_read_back_as_the_same_float32(vertices: np.ndarray) -> None:
    rows = _read(vertex_lines(vertices.astype(np.float64), single=True).decode("ascii"))
    read = np.array([[np.float32(word) for word in words[1:]] for words in rows], dtype=np.float32)
    assert read.view(np.int32).tolist() == vertices.view(np.int32).tolist()
    shortest = [_significant(str(value)) for value in vertices.ravel()]
    assert [_significant(word) for words in rows for word in words[1:]] == shortest


def test_plain_values_are_written_plainly() -> None:
    data = vertex_lines(np.array([[1.0, -0.0, 0.1], [7.2296, 1e-5, 1e20]]))
    assert data == b"v 1 -0 0.1\nv 7.2296 0.00001 1e+20\n"


def test_what_is_written_reads_back_bit_for_bit_without_importing_pandas() -> None:
    code = (
        "import sys, numpy as np; from rigs._arrow_lines import read_vertex_lines, vertex_lines; "
        "v = np.random.default_rng(0).normal(size=(1000, 3)) * 7; "
        "assert read_vertex_lines(vertex_lines(v).decode()).tobytes() == v.tobytes(); "
        "assert 'pandas' not in sys.modules, 'pandas imported'"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_a_block_with_any_other_line_is_not_read() -> None:
    block = vertex_lines(np.eye(3)).decode("ascii")
    assert np.array_equal(read_vertex_lines(block), np.eye(3))
    for other in ("vt 1 2 3\n", "v 1 2 3 4\n", "v 1  2 3\n", "v 1 2\n", "v 1_0 2 3\n", "v 1 2 3 é\n", ""):
        assert read_vertex_lines(block + other if other else "") is None, other


@settings(deadline=None)
@given(hnp.arrays(np.int64, st.tuples(st.integers(0, 20), st.just(3)), elements=st.integers(0, 2**62)))
def test_triangles_are_written_one_based_as_python_writes_integers(triangles: np.ndarray) -> None:
    expected = "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in triangles.tolist())
    assert triangle_lines(triangles) == expected.encode("ascii")
