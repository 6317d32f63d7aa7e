"""Writing a report as Markdown (figures beside it) and as one self-contained HTML page (figures inline)."""

from __future__ import annotations

import base64
import html
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from registry import claim

#: The HTML page may load nothing from anywhere: only inline styles and images embedded as data URIs.
CONTENT_SECURITY_POLICY = "default-src 'none'; img-src data:; style-src 'unsafe-inline'"

_CSS = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1400px; padding: 0 1em; color: #222; }
table { border-collapse: collapse; margin: 0.5em 0 1.5em; font-size: 0.85em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.5em; text-align: right; }
th { background: #f0f0f0; }
td.text { text-align: left; }
figure { margin: 1em 0 2em; }
figure img { max-width: 100%; height: auto; border: 1px solid #eee; }
figcaption { font-size: 0.85em; color: #555; }
details > summary { cursor: pointer; font-size: 1.5em; font-weight: bold; margin: 0.83em 0; }
@page { size: A4; margin: 12mm; }
@media print {
  body { margin: 0; max-width: none; padding: 0; font-size: 9pt; }
  table { font-size: 6.5pt; width: 100%; table-layout: auto; }
  th, td { padding: 0.1em 0.25em; overflow-wrap: anywhere; }
  figure, tr { break-inside: avoid; }
  details::details-content { content-visibility: visible; display: block; }
  details > summary { list-style: none; }
}
"""


@dataclass(frozen=True)
class Image:
    """A figure of the report: file stem, bytes, caption and format (``png`` for plots, ``jpeg`` for
    renders, whose many shades a PNG stores at many times the size)."""

    name: str
    png: bytes
    caption: str
    format: str = "png"

    @property
    def file(self) -> str:
        """The figure's file name: stem and extension."""
        return f"{self.name}.{'jpg' if self.format == 'jpeg' else self.format}"


Block = str | pd.DataFrame | Image


@dataclass(frozen=True)
class Section:
    """A titled part of the report: paragraphs (str), tables (DataFrame) and figures (Image), in order; a
    ``folded`` section is detail, closed on screen until opened (and printed whole)."""

    title: str
    blocks: Sequence[Block]
    folded: bool = False


def format_cell(value: object) -> str:
    """Text of one table cell: 4 significant digits for floats, an en dash for missing values."""
    if value is None or (isinstance(value, float) and math.isnan(value)) or value is pd.NA:
        return "\u2013"
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def _rows(table: pd.DataFrame) -> list[list[str]]:
    return [[format_cell(value) for value in row] for row in table.astype(object).itertuples(index=False)]


def markdown(title: str, sections: Sequence[Section], figures_dir: str) -> str:
    """The report as GitHub-flavoured Markdown; figures are referenced as ``figures_dir/<name>.png``."""
    lines = [f"# {title}", ""]
    for section in sections:
        lines += [f"## {section.title}", ""]
        for block in section.blocks:
            if isinstance(block, Image):
                lines += [f"![{block.caption}]({figures_dir}/{block.file})", "", f"*{block.caption}*", ""]
            elif isinstance(block, pd.DataFrame):
                header = [str(column) for column in block.columns]
                lines.append("| " + " | ".join(header) + " |")
                lines.append("|" + "---|" * len(header))
                for row in _rows(block):
                    lines.append("| " + " | ".join(cell.replace("|", "\\|") for cell in row) + " |")
                lines.append("")
            else:
                lines += [block, ""]
    return "\n".join(lines)


def _html_table(table: pd.DataFrame) -> str:
    numeric = [pd.api.types.is_numeric_dtype(dtype) for dtype in table.dtypes]
    head = "".join(f"<th>{html.escape(str(column))}</th>" for column in table.columns)
    body = "".join(
        "<tr>"
        + "".join(
            f"<td>{html.escape(cell)}</td>" if is_number else f'<td class="text">{html.escape(cell)}</td>'
            for cell, is_number in zip(row, numeric, strict=True)
        )
        + "</tr>"
        for row in _rows(table)
    )
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def html_page(title: str, sections: Sequence[Section]) -> str:
    """The report as one HTML page that loads nothing: styles inline, figures as base64 ``data:`` URIs."""
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f'<meta http-equiv="Content-Security-Policy" content="{CONTENT_SECURITY_POLICY}">',
        f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>",
        f"<h1>{html.escape(title)}</h1>",
    ]
    for section in sections:
        title = html.escape(section.title)
        parts.append(f"<details><summary>{title}</summary>" if section.folded else f"<h2>{title}</h2>")
        for block in section.blocks:
            if isinstance(block, Image):
                data = base64.b64encode(block.png).decode("ascii")
                parts.append(
                    f'<figure><img alt="{html.escape(block.caption)}" '
                    f'src="data:image/{block.format};base64,{data}">'
                    f"<figcaption>{html.escape(block.caption)}</figcaption></figure>"
                )
            elif isinstance(block, pd.DataFrame):
                parts.append(_html_table(block))
            else:
                parts.append(f"<p>{html.escape(block)}</p>")
        if section.folded:
            parts.append("</details>")
    parts.append("</body></html>")
    return "\n".join(parts)


def write_documents(title: str, sections: Sequence[Section], directory: Path) -> tuple[Path, Path]:
    """Write ``index.html``, ``report.md`` and ``figures/*`` as the whole content of ``directory``
    (`registry.claim`, kind ``report``: an earlier report is replaced, a folder holding anything else is
    refused); return both pages.

    Raises
    ------
    registry.OutputFolderError
        When ``directory`` holds files no report wrote (naming them) or cannot be written.
    """
    figures = {
        f"figures/{block.file}": block.png
        for section in sections
        for block in section.blocks
        if isinstance(block, Image)
    }
    with claim(directory, kind="report", force=True, lock=True) as folder:
        page, text, *_ = folder.replace(
            {
                "index.html": html_page(title, sections),
                "report.md": markdown(title, sections, "figures"),
                **figures,
            }
        )
    return page, text
