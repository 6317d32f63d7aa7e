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
    """Render ``figure`` to PNG bytes on the Agg canvas, without any timestamp or version metadata."""
    buffer = io.BytesIO()
    with report_style():
        figure.savefig(buffer, format="png", dpi=DPI, metadata={"Software": None})
    return buffer.getvalue()
