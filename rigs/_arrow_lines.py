"""OBJ ``v x y z`` lines written and read by Arrow's CSV writer and reader, and ``f a b c`` lines written.

Both run in C++ outside the interpreter lock and several times faster than Python's number formatting and
parsing on the tens of thousands of vertices of a production head. Arrow formats each number as the shortest
text that reads back as the same float and reads decimal text to the correctly rounded float, as Python does.

Columns are built from and read into numpy buffers directly: ``pyarrow.array`` and ``to_numpy`` would import
pandas (a quarter of a second) to check for its types.
"""

from __future__ import annotations

import numpy as np
import pyarrow as pa
from pyarrow import csv

#: The keyword column of vertex lines: every row read must hold this one-character word.
_KEYWORD = "v"
_COLUMNS = ("keyword", "x", "y", "z")
_WRITE = csv.WriteOptions(include_header=False, delimiter=" ", quoting_style="none")
#: Blocks of 64 MiB: a production head's vertex lines are read as one block.
_READ = csv.ReadOptions(column_names=list(_COLUMNS), use_threads=False, block_size=1 << 26)
_PARSE = csv.ParseOptions(delimiter=" ", quote_char=False, ignore_empty_lines=False)
_CONVERT = csv.ConvertOptions(
    column_types={"keyword": pa.string()} | dict.fromkeys(_COLUMNS[1:], pa.float64()),
    null_values=[],
    strings_can_be_null=False,
)


def _keyword_column(word: str, count: int) -> pa.DictionaryArray:
    """``count`` rows of ``word``."""
    encoded = word.encode("ascii")
    offsets = pa.py_buffer(np.array([0, len(encoded)], dtype=np.int32))
    dictionary = pa.Array.from_buffers(pa.string(), 1, [None, offsets, pa.py_buffer(encoded)])
    indices = pa.Array.from_buffers(pa.int8(), count, [None, pa.py_buffer(np.zeros(count, dtype=np.int8))])
    return pa.DictionaryArray.from_arrays(indices, dictionary)


#: Arrow types of the numpy types written.
_ARROW_TYPES = {
    np.dtype(np.float64): pa.float64(),
    np.dtype(np.float32): pa.float32(),
    np.dtype(np.int64): pa.int64(),
}


def _keyword_lines(word: str, columns: np.ndarray) -> bytes:
    """Lines of ``word`` and the values of a row of the (rows, values) array ``columns``, one space between
    words, each line ending in a line feed."""
    arrays = [_keyword_column(word, len(columns))]
    for values in columns.T:
        values = np.ascontiguousarray(values)
        kind = _ARROW_TYPES[values.dtype]
        arrays.append(pa.Array.from_buffers(kind, len(values), [None, pa.py_buffer(values)]))
    names = ["keyword", *(f"c{index}" for index in range(columns.shape[1]))]
    sink = pa.BufferOutputStream()
    csv.write_csv(pa.RecordBatch.from_arrays(arrays, names=names), sink, _WRITE)
    return sink.getvalue().to_pybytes()


def vertex_lines(vertices: np.ndarray, *, single: bool = False) -> bytes:
    """``v x y z`` lines (ASCII), each ending in a line feed, every coordinate the shortest text that reads
    back as the same float64 (``single``: float32): ``1`` for 1.0, ``-0``, ``0.00001``, ``1e+20``."""
    vertices = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    return _keyword_lines(_KEYWORD, vertices.astype(np.float32) if single else vertices)


def triangle_lines(triangles: np.ndarray) -> bytes:
    """``f a b c`` lines (ASCII) of (T, 3) zero-based triangles, written one-based."""
    return _keyword_lines("f", np.asarray(triangles, dtype=np.int64).reshape(-1, 3) + 1)


def read_vertex_lines(block: str | bytes) -> np.ndarray | None:
    """(N, 3) positions of text made only of ``v x y z`` lines (one space between words, each line ending
    in a line feed); None when any line is anything else or a number does not read (Arrow refuses
    ``1_000`` and non-ASCII digits, which Python's ``float`` takes)."""
    try:
        table = csv.read_csv(
            pa.py_buffer(block.encode("ascii") if isinstance(block, str) else block),
            read_options=_READ,
            parse_options=_PARSE,
            convert_options=_CONVERT,
        )
    except (pa.ArrowInvalid, UnicodeEncodeError):
        return None
    keywords = table.column("keyword").chunks
    if not keywords or not all(map(_only_keyword, keywords)):
        return None
    return np.column_stack([_floats(table.column(axis)) for axis in _COLUMNS[1:]])


def _only_keyword(chunk: pa.StringArray) -> bool:
    """Whether every value of a string column chunk is `_KEYWORD` (read from its offsets and bytes)."""
    offsets = np.frombuffer(chunk.buffers()[1], dtype=np.int32, count=len(chunk) + 1, offset=4 * chunk.offset)
    if not (np.diff(offsets) == len(_KEYWORD)).all():
        return False
    data = np.frombuffer(chunk.buffers()[2], dtype=np.uint8)[offsets[0] : offsets[-1]]
    return bool((data == ord(_KEYWORD)).all())


def _floats(column: pa.ChunkedArray) -> np.ndarray:
    """A float64 column without nulls as one numpy array (read from the chunks' buffers)."""
    return np.concatenate(
        [
            np.frombuffer(chunk.buffers()[1], dtype=np.float64, count=len(chunk), offset=8 * chunk.offset)
            for chunk in column.chunks
        ]
    )
