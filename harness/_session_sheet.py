"""``session.html``: the one-page scan sheet of a scanning session, for the screen and for print.

One card per expression in priority order (the sequence order of Algorithm 1, most important first,
Carrigan et al. 2020, sec. 4.5): its front picture, its priority and importance (eq. 3a), and its shapes
in plain words (`harness._session_words.plain_words`) with the colour each has in the picture. The page
needs nothing but the pictures beside it (no script, no web font); cards never break across pages and the
grid and the pictures are sized (`sheet_layout`) so that the whole sequence fits one A4 page.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from html import escape
from typing import Any, TypedDict

import numpy as np

#: Each shape of an expression as its picture shows it: ``(plain words, shape name, RGB colour, extra?)``.
Legend = list[tuple[str, str, np.ndarray, bool]]


class Card(TypedDict):
    """One expression of the scan sheet: the relative path of its front picture (or None), its importance
    (``objective``, eq. 3a) and its `Legend`."""

    picture: str | None
    objective: float
    legend: Legend


_STYLE = """
@page { size: A4 portrait; margin: 9mm; }
* { box-sizing: border-box; }
html { -webkit-print-color-adjust: exact; print-color-adjust: exact; }
body { font: 8.5pt/1.25 "DejaVu Sans", Arial, sans-serif; color: #111; background: #fff; margin: 0 auto;
       max-width: 192mm; }
header h1 { font-size: 13pt; margin: 0 0 1mm; }
header p { font-size: 7.5pt; color: #333; margin: 0 0 2.5mm; }
.grid { display: grid; grid-template-columns: repeat(var(--columns), 1fr); gap: 2mm; }
.card { border: 0.25mm solid #888; border-radius: 1mm; padding: 1.2mm; break-inside: avoid;
        page-break-inside: avoid; }
.card h2 { font-size: 8.5pt; margin: 0 0 0.6mm; display: flex; justify-content: space-between; }
.card h2 small { font-weight: normal; color: #444; }
.face { overflow: hidden; height: var(--face-height); width: calc(var(--face-height) * var(--face-aspect));
        max-width: 100%; margin: 0 auto; }
.face img { display: block; width: var(--face-zoom); height: auto; }
.card ul { list-style: none; margin: 0.6mm 0 0; padding: 0; font-size: var(--text); }
.card li { white-space: nowrap; overflow: hidden; text-overflow: ellipsis; }
.swatch { display: inline-block; width: 0.7em; height: 0.7em; margin-right: 0.35em; vertical-align: -0.05em;
          border: 0.1mm solid #0003; }
.extra { color: #555; font-style: italic; }
footer { margin-top: 2mm; font-size: 6.5pt; color: #444; }
"""


#: The page's usable width and height in millimetres (A4 less the margins), the gap between cards, a card's
#: padding and border, a card's heading, the header's height and the line height per point of text.
_PAGE = (192.0, 279.0)
_GAP, _PADDING, _HEADING, _HEADER, _LINE = 2.0, 3.0, 5.0, 16.0, 0.3528 * 1.3
#: Characters of a footer line (6.5 pt across the page).
_NOTE_WIDTH = 140


def sheet_layout(cards: int, lines: int, aspect: float, notes: int = 0) -> tuple[int, float, float]:
    """Columns, picture height (mm) and text size (pt) that fit ``cards`` on one A4 page.

    Every column count is tried; each card's picture is as tall as its column width and its row's height
    (after its heading and ``lines`` lines of shape names) allow, and the layout with the largest picture
    wins. ``aspect`` is a picture's width over its height, ``notes`` the footer's lines.
    """
    best = (1, 0.0, 7.5)
    for columns in range(1, max(1, cards) + 1):
        rows = -(-max(1, cards) // columns)
        text = max(5.0, min(7.5, 30.0 / max(2, columns)))
        width = (_PAGE[0] - _GAP * (columns - 1)) / columns - _PADDING
        height = (_PAGE[1] - _HEADER - notes * 6.5 * _LINE - _GAP * (rows - 1)) / rows
        picture = min(width / aspect, height - _PADDING - _HEADING - lines * text * _LINE)
        if picture > best[1]:
            best = (columns, picture, text)
    return best


def scan_sheet(
    document: Mapping[str, Any],
    cards: Sequence[Card],
    *,
    title: str,
    face: tuple[float, float] = (1.0, 1.0),
    notes: Sequence[str] = (),
) -> str:
    """The HTML text of the scan sheet.

    Parameters
    ----------
    document : mapping
        ``expressions.json`` (its solver and parameters are summarised in the header).
    cards : sequence of Card
        Per expression, in priority order.
    title : str
        The rig's name.
    face : (share of width, aspect)
        Where the face is in a picture: the share of its width from the left edge, and that part's width
        over its height; the card shows that part (the picture's own legend is left out: the card lists
        the shapes).
    notes : sequence of str
        Lines for the footer (what was left out and why).
    """
    lines = max([len(card["legend"]) for card in cards] + [1])
    wrapped = sum(-(-len(note) // _NOTE_WIDTH) for note in notes)
    columns, height, text = sheet_layout(len(cards), lines, face[1], wrapped)
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en">',
        "<head>",
        '<meta charset="utf-8">',
        f"<title>Scan session: {escape(title)}</title>",
        f"<style>{_STYLE}</style>",
        "</head>",
        f'<body style="--columns: {columns}; --text: {text:.1f}pt; --face-height: {max(height, 10.0):.1f}mm; '
        f'--face-aspect: {face[1]:.4f}; --face-zoom: {100.0 / face[0]:.2f}%">',
        "<header>",
        f"<h1>Scan session: {escape(title)}</h1>",
        f"<p>{escape(_summary(document, len(cards)))}</p>",
        "</header>",
        '<main class="grid">',
    ]
    for priority, card in enumerate(cards, start=1):
        parts.append(_card(priority, card))
    parts.append("</main>")
    if notes:
        parts.append("<footer>" + "<br>".join(escape(note) for note in notes) + "</footer>")
    parts += ["</body>", "</html>", ""]
    return "\n".join(parts)


def _summary(document: Mapping[str, Any], count: int) -> str:
    params = document.get("params", {})
    shapes = sum(len(expression["shapes"]) for expression in document.get("expressions", []))
    words = [
        f"{count} expressions covering {shapes} blendshapes, by {document.get('solver', '?')}",
        f"mu {params.get('mu')}",
        "symmetry on" if params.get("symmetry") else "symmetry off",
    ]
    if params.get("max_per_expression"):
        words.append(f"at most {params['max_per_expression']} shapes per expression")
    words.append("scan in priority order: 1 first")
    return "; ".join(words) + "."


def _card(priority: int, card: Card) -> str:
    lines = [
        '<section class="card">',
        f"<h2>Priority {priority} <small>importance {float(card['objective']):.3g}</small></h2>",
    ]
    if card.get("picture"):
        picture = f'<img src="{escape(card["picture"])}" alt="expression {priority}, front">'
        lines.append(f'<div class="face">{picture}</div>')
    lines.append("<ul>")
    for words, name, colour, extra in card["legend"]:
        rgb = ",".join(str(int(round(255 * float(c)))) for c in np.asarray(colour).ravel()[:3])
        style = ' class="extra"' if extra else ""
        suffix = " (again)" if extra else ""
        lines.append(
            f'<li{style} title="{escape(name)}"><span class="swatch" style="background: rgb({rgb})"></span>'
            f"{escape(words)}{suffix}</li>"
        )
    lines += ["</ul>", "</section>"]
    return "\n".join(lines)
