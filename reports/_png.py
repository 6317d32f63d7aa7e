"""Deterministic, headless matplotlib output: same records, same PNG bytes."""

from __future__ import annotations

import io
from collections.abc import Iterator
from contextlib import contextmanager

import matplotlib
from matplotlib.figure import Figure

#: Resolution of every saved figure, in dots per inch.
DPI = 100

_STYLE = {
    "font.family": "DejaVu Sans",  # shipped with matplotlib, so every machine draws the same glyphs
    "font.size": 9,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "svg.hashsalt": "expression-packing-report",
    "path.simplify": False,
}


@contextmanager
def report_style() -> Iterator[None]:
    """Apply the report's fixed matplotlib settings while figures are built and saved."""
    with matplotlib.rc_context(_STYLE):
        yield


def png_bytes(figure: Figure) -> bytes:
    """Render ``figure`` to PNG bytes on the Agg canvas, without any timestamp or version metadata, in a
    palette of 256 colours (a plot has few: the anti-aliased edges of its lines need no more; a third of
    the size)."""
    from PIL import Image

    buffer = io.BytesIO()
    with report_style():
        figure.savefig(buffer, format="png", dpi=DPI, metadata={"Software": None})
    buffer.seek(0)
    with Image.open(buffer) as image:
        quantized = image.convert("RGB").quantize(
            256, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE
        )
    out = io.BytesIO()
    quantized.save(out, format="png", optimize=True)
    return out.getvalue()


#: JPEG quality of rendered pictures (contact sheets): the shading of a render loses nothing one can see.
JPEG_QUALITY = 70


def jpeg_bytes(figure: Figure) -> bytes:
    """Render ``figure`` to JPEG bytes (for renders: a sixth of the PNG's size), without metadata."""
    buffer = io.BytesIO()
    with report_style():
        figure.savefig(buffer, format="jpeg", dpi=DPI, pil_kwargs={"quality": JPEG_QUALITY, "optimize": True})
    return buffer.getvalue()
