"""Bounded reading of NumPy ``.npz`` archives: every member's size is checked before it is allocated.

``np.load`` trusts each ``.npy`` header: a header claiming a shape of 218 TiB makes it allocate that much
before reading a byte. Here each member's header (read with :mod:`numpy.lib.format`) must describe
exactly the bytes the zip directory says the member holds, the directory's claim must be within what
deflate can produce from the compressed bytes, and all members together must fit the budget of
:func:`rigs._safe.check_budget`. Only then is any array read, by ``numpy.lib.format.read_array`` without
pickle, and each member is read to its end so that its CRC is checked.
"""

from __future__ import annotations

import io
import math
import zipfile
import zlib

import numpy as np
from numpy.lib import format as npy_format

from rigs._rig import RigError
from rigs._safe import check_budget, check_ratio, size_text

_ARCHIVE_ERRORS = (
    zipfile.BadZipFile,
    zlib.error,
    OSError,
    EOFError,
    ValueError,
    NotImplementedError,
    RuntimeError,
)


class NpzArchive:
    """The members of one ``.npz`` archive, their headers checked against the archive's bytes.

    Parameters
    ----------
    data : bytes
        The archive's content (already read from a regular file).
    source : str
        The file, for messages.

    Attributes
    ----------
    headers : dict str -> (shape, dtype)
        Each key (member name without ``.npy``) with its declared shape and dtype.

    Raises
    ------
    RigError
        One line naming the file and the problem: not a zip archive, a member that is not ``.npy``, a key
        twice, a malformed header, an object dtype (it would need pickle), a header whose shape and dtype
        disagree with the member's size, or arrays too large for the file (see `check_budget`).
    """

    def __init__(self, data: bytes, source: str) -> None:
        self.source = source
        try:
            self._archive = zipfile.ZipFile(io.BytesIO(data))
            infos = self._archive.infolist()
        except _ARCHIVE_ERRORS as error:
            raise RigError(f"{source}: not a NumPy .npz archive ({error})") from None
        self._infos: dict[str, zipfile.ZipInfo] = {}
        self.headers: dict[str, tuple[tuple[int, ...], np.dtype]] = {}
        for info in infos:
            if not info.filename.endswith(".npy"):
                raise RigError(f"{source}: member {info.filename!r} is not a .npy array")
            key = info.filename[: -len(".npy")]
            if key in self._infos:
                raise RigError(f"{source}: key {key!r} appears twice in the archive")
            self._infos[key] = info
            self.headers[key] = self._header(key, info)
        total = sum(math.prod(shape) * dtype.itemsize for shape, dtype in self.headers.values())
        check_budget(source, "the arrays", total, len(data))

    def _header(self, key: str, info: zipfile.ZipInfo) -> tuple[tuple[int, ...], np.dtype]:
        label = f"{self.source}: key {key!r}"
        check_ratio(info, label)
        try:
            with self._archive.open(info) as stream:
                version = npy_format.read_magic(stream)
                if version == (1, 0):
                    shape, _, dtype = npy_format.read_array_header_1_0(stream)
                elif version == (2, 0):
                    shape, _, dtype = npy_format.read_array_header_2_0(stream)
                else:
                    raise RigError(f"{label}: .npy format version {version} is not a rig array's")
                header_size = stream.tell()
        except RigError:
            raise
        except _ARCHIVE_ERRORS as error:
            raise RigError(f"{label} is corrupt ({error})") from None
        if dtype.hasobject:
            raise RigError(f"{label} cannot be read without pickle (it holds Python objects)")
        if any(extent < 0 for extent in shape):
            raise RigError(f"{label} has a negative extent in its shape {shape}")
        claimed = math.prod(shape) * dtype.itemsize
        if header_size + claimed != info.file_size:
            raise RigError(
                f"{label}: its header claims shape {shape} of {dtype} ({size_text(claimed)}), but the "
                f"archive holds {size_text(max(info.file_size - header_size, 0))} for it"
            )
        return tuple(shape), dtype

    def read(self, key: str) -> np.ndarray:
        """The array of ``key``, read to the member's end (CRC checked)."""
        try:
            with self._archive.open(self._infos[key]) as stream:
                array = npy_format.read_array(stream, allow_pickle=False)
                if stream.read(1):
                    raise ValueError("data after the array")
        except _ARCHIVE_ERRORS as error:
            raise RigError(f"{self.source}: key {key!r} is corrupt ({error})") from None
        return array

    def close(self) -> None:
        self._archive.close()

    def __enter__(self) -> NpzArchive:
        return self

    def __exit__(self, *_: object) -> None:
        self.close()
