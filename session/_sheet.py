"""``session.html``: the scan sheet of a scanning session, for the screen and for print.

One card per expression in priority order (the sequence order of Algorithm 1, most important first,
Carrigan et al. 2020, sec. 4.5): its pictures (`session._pictures`: the shapes coloured, the bare
pose from the front and at three-quarters) captioned in the page, its priority and importance (eq. 3a),
and its shapes in plain words (`session._words.plain_words`) with the colour each has in the
picture. The page says what to do in a rigging TD's words, with no reference to the paper.

The page needs nothing but the pictures beside it (no script, no web font). It prints on A4 and on US
Letter alike: the layout (`sheet_layout`) is made for the part of the page both papers have inside
10 mm margins, every column shrinks with the page (``minmax(0, 1fr)``), no text is smaller than 7 pt,
and cards never break across pages.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from html import escape
from typing import Any, TypedDict

import numpy as np

from session._pictures import FACE_SHARE, PAINTED, SIZE, picture_files

#: Each shape of an expression as its picture shows it: ``(plain words, shape name, RGB colour, extra?)``.
Legend = list[tuple[str, str, np.ndarray, bool]]


class Card(TypedDict):
    """One expression of the scan sheet: its ``files`` (``expressions.json``'s, relative paths of its
    pictures among them), its importance (``objective``, eq. 3a) and its `Legend`."""

    files: Mapping[str, str]
    objective: float
    legend: Legend


#: What the sheet tells the TD, before the cards.
INSTRUCTIONS = (
    "Scan the expressions in priority order, 1 first: a session cut short has the most important "
    "shapes. For each card the actor holds every listed shape at once, at full strength, to match the "
    "bare pose pictures; the coloured picture shows what each shape moves. Left and right are the "
    "actor's own: the actor's left is on the right of a front picture, and the three-quarter view "
    "shows the actor's left side. \u201c(again)\u201d marks a shape already scanned, held again in "
    "another combination."
)
#: Captions of the pictures, by their key in an expression's ``files``.
CAPTIONS = {PAINTED: "shapes", "front_pose": "front", "three_quarter_pose": "\u00be view"}

#: Millimetres: the width of A4 and the height of US Letter less 10 mm margins (what both papers hold),
#: the gap between cards, a card's padding and border, the gap between pictures.
_PAGE = (190.0, 259.0)
#: Millimetres of the page's height the layout leaves free: text heights are estimated, not measured.
_SPARE = 4.0
_GAP, _PADDING, _PICTURE_GAP = 2.0, 3.0, 0.8
#: Text sizes in points (none below 7) and the line height per point of text in millimetres.
_TEXT, _HEADING, _TITLE, _LINE = 7.0, 8.0, 12.0, 0.3528 * 1.25
#: Width of an average character per point of text in millimetres (DejaVu Sans and Arial, with room).
_CHARACTER = 0.3528 * 0.6
#: The smallest picture height (mm) a layout gives; below it the sheet takes more pages.
_SMALLEST_PICTURE = 14.0
#: The narrowest a card's inside may be (mm): a dozen characters of 7 pt text.
_NARROWEST = 18.0

_STYLE = """
@page { margin: 10mm; }
* { box-sizing: border-box; }
html { -webkit-print-color-adjust: exact; print-color-adjust: exact; }
body { font: 8pt/1.25 "DejaVu Sans", Arial, sans-serif; color: #111; background: #fff; margin: 0 auto;
       max-width: 190mm; }
header h1 { font-size: 12pt; margin: 0 0 1mm; }
header p { font-size: 7.5pt; color: #222; margin: 0 0 1.5mm; }
.grid { display: grid; grid-template-columns: repeat(var(--columns), minmax(0, 1fr)); gap: 2mm; }
.card { border: 0.25mm solid #888; border-radius: 1mm; padding: 1.25mm; break-inside: avoid;
        page-break-inside: avoid; min-width: 0; }
.card h2 { font-size: 8pt; line-height: 1.25; margin: 0 0 0.6mm; }
.card h2 span { display: block; white-space: nowrap; }
.card h2 small { display: block; font-size: 7pt; font-weight: normal; color: #444; }
.views { display: grid; grid-template-columns: repeat(var(--per-row), minmax(0, 1fr)); gap: 0.8mm; }
figure { margin: 0; min-width: 0; text-align: center; }
.face { overflow: hidden; height: var(--face-height); width: calc(var(--face-height) * var(--face-aspect));
        max-width: 100%; margin: 0 auto; }
.face img { display: block; height: 100%; width: auto; }
.face.painted img { width: var(--face-zoom); height: auto; }
figcaption { font-size: 7pt; color: #444; white-space: nowrap; overflow: hidden; text-overflow: clip; }
.card ul { list-style: none; margin: 0.6mm 0 0; padding: 0; font-size: 7pt; line-height: 1.25; }
.card li { padding-left: 1.05em; text-indent: -1.05em; overflow-wrap: anywhere; }
.swatch { display: inline-block; width: 0.75em; height: 0.75em; margin-right: 0.3em; vertical-align: -0.05em;
          border: 0.1mm solid #0003; text-indent: 0; }
.extra { color: #555; font-style: italic; }
footer { margin-top: 2mm; font-size: 7pt; color: #333; }
footer p { margin: 0 0 0.8mm; }
"""


@dataclass(frozen=True)
class Layout:
    """Cards across (``columns``), pictures across a card (``per_row``) and the picture height (mm)."""

    columns: int
    per_row: int
    picture: float


def sheet_layout(
    cards: Sequence[Sequence[str]],
    pictures: int,
    aspect: float,
    *,
    header: Sequence[str] = (),
    footer: Sequence[str] = (),
) -> Layout:
    """The layout that gives the largest pictures with every card on one page (`_PAGE`).

    Every column count that leaves a card `_NARROWEST` wide and every number of pictures across a card is
    tried; a card's text wraps at its width (estimated from the characters per line), a row of cards is
    as tall as its tallest card, and the pictures are as tall as the cards' width and the page's height
    allow. When no layout keeps the pictures `_SMALLEST_PICTURE` tall on one page, they take that height
    in the layout of the shortest sheet, whose cards flow onto more pages; without pictures, the widest
    cards that fit one page (else the shortest sheet).

    Parameters
    ----------
    cards : sequence of sequence of str
        The text lines of each card (its shapes).
    pictures : int
        Pictures per card.
    aspect : float
        A picture's width over its height.
    header, footer : sequence of str
        Paragraphs above and below the cards (7.5 and 7 pt, across the page).
    """
    width, height = _PAGE[0], _PAGE[1] - _SPARE
    fixed = _TITLE * _LINE + sum(_lines(text, width, 7.5) * 7.5 * _LINE + 1.5 for text in header)
    fixed += sum(_lines(text, width, _TEXT) * _TEXT * _LINE + 0.8 for text in footer) + 2.0 * bool(footer)
    widest = max(1, min(len(cards), int((width + _GAP) // (_NARROWEST + _PADDING + _GAP))))
    grids = [_grid(cards, columns) for columns in range(1, widest + 1)]
    if not pictures:
        fitting = [columns for columns, (_, _, text) in enumerate(grids, start=1) if text <= height - fixed]
        return Layout(fitting[0] if fitting else 1 + int(np.argmin([grid[2] for grid in grids])), 1, 0.0)
    largest, shortest = Layout(1, 1, 0.0), (np.inf, Layout(1, 1, _SMALLEST_PICTURE))
    for columns, (inner, rows, text) in enumerate(grids, start=1):
        for per_row in range(1, pictures + 1):
            picture_rows = -(-pictures // per_row)
            by_width = (inner - _PICTURE_GAP * (per_row - 1)) / per_row / aspect
            extra = rows * picture_rows * (_TEXT * _LINE + _PICTURE_GAP)  # captions and gaps
            picture = min(by_width, (height - fixed - text - extra) / (rows * picture_rows))
            if picture > largest.picture:
                largest = Layout(columns, per_row, picture)
            total = text + extra + rows * picture_rows * _SMALLEST_PICTURE
            if by_width >= _SMALLEST_PICTURE and total < shortest[0]:
                shortest = (total, Layout(columns, per_row, _SMALLEST_PICTURE))
    return largest if largest.picture >= _SMALLEST_PICTURE else shortest[1]


def _grid(cards: Sequence[Sequence[str]], columns: int) -> tuple[float, int, float]:
    """A card's inside width (mm), the rows of cards and the height (mm) of their text and frames, in
    ``columns`` columns."""
    inner = (_PAGE[0] - _GAP * (columns - 1)) / columns - _PADDING
    starts = range(0, max(1, len(cards)), columns)
    text = sum(
        max((_card_text(card, inner) for card in cards[row : row + columns]), default=0.0) for row in starts
    )
    return inner, len(starts), text + (_GAP + _PADDING) * len(starts)


def _lines(text: str, width: float, points: float) -> int:
    """Lines ``text`` takes at ``points`` in ``width`` millimetres (at least 1)."""
    return max(1, -(-round(len(text) * _CHARACTER * points * 100) // round(width * 100)))


def _card_text(lines: Sequence[str], inner: float) -> float:
    """Height (mm) of a card's heading (its priority, then its importance) and shape lines at ``inner``
    millimetres wide."""
    heading = _HEADING * _LINE + _lines("importance 0.000", inner, _TEXT) * _TEXT * _LINE
    shapes = sum(_lines(line, inner - 1.05 * _TEXT * 0.3528, _TEXT) for line in lines)
    return heading + 0.6 + shapes * _TEXT * _LINE + 0.6


def scan_sheet(
    document: Mapping[str, Any], cards: Sequence[Card], *, title: str, notes: Sequence[str] = ()
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
    notes : sequence of str
        What packing noted (what was left out and why), for the footer; references to the paper's
        equations and sections are left out (`plain_note`).
    """
    texts = [[_shape_text(entry) for entry in card["legend"]] for card in cards]
    shown = max((len(picture_files(card["files"])) for card in cards), default=0)
    summary = _summary(document, len(cards))
    footer = [plain_note(note) for note in notes]
    aspect = FACE_SHARE * SIZE[0] / SIZE[1]
    layout = sheet_layout(texts, shown, aspect, header=[summary, INSTRUCTIONS], footer=footer)
    style = (
        f"--columns: {layout.columns}; --per-row: {layout.per_row}; --face-height: {layout.picture:.1f}mm; "
        f"--face-aspect: {aspect:.4f}; --face-zoom: {100.0 / FACE_SHARE:.2f}%"
    )
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en">',
        "<head>",
        '<meta charset="utf-8">',
        f"<title>Scan session: {escape(title)}</title>",
        f"<style>{_STYLE}</style>",
        "</head>",
        f'<body style="{style}">',
        "<header>",
        f"<h1>Scan session: {escape(title)}</h1>",
        f"<p>{escape(summary)}</p>",
        f"<p>{escape(INSTRUCTIONS)}</p>",
        "</header>",
        '<main class="grid">',
    ]
    for priority, card in enumerate(cards, start=1):
        parts.append(_card(priority, card))
    parts.append("</main>")
    if footer:
        parts.append("<footer>" + "".join(f"<p>{escape(note)}</p>" for note in footer) + "</footer>")
    parts += ["</body>", "</html>", ""]
    return "\n".join(parts)


#: A reference to the paper in a note: ``(eq. 2)``, ``(eqs. 6-7)``, ``, sec. 4.4.1`` and the like.
_REFERENCE = re.compile(
    r"\s*\((?:eqs?|sec|secs|Algorithm|Alg)\.?\s[^()]*\)|,\s*(?:eqs?|secs?)\.\s[\d.\-\u2013, and]*\d(?=\))"
    r"|\s*\b(?:eqs?|secs?)\.\s[\d.\-\u2013]*\d",
    re.IGNORECASE,
)


def plain_note(note: str) -> str:
    """``note`` without its references to the paper's equations, sections and algorithms.

    Examples
    --------
    >>> plain_note("no target neutral: triangle distortion (eqs. 6-7) is 0")
    'no target neutral: triangle distortion is 0'
    >>> plain_note("not paired (they spread over both halves, sec. 4.4.1): jawLeft+jawRight")
    'not paired (they spread over both halves): jawLeft+jawRight'
    """
    return _REFERENCE.sub("", note)


def _summary(document: Mapping[str, Any], count: int) -> str:
    params = document.get("params", {})
    shapes = sum(len(expression["shapes"]) for expression in document.get("expressions", []))
    words = [
        f"{count} expressions covering {shapes} blendshapes, chosen by {document.get('solver', '?')}",
        f"threshold mu {params.get('mu')}",
        "left and right shapes kept together" if params.get("symmetry") else "left and right shapes apart",
    ]
    if params.get("max_per_expression"):
        most = params["max_per_expression"]
        words.append(f"at most {most} shape{'s' if most > 1 else ''} per expression")
    return "; ".join(words) + "."


def _shape_text(entry: tuple[str, str, np.ndarray, bool]) -> str:
    words, _, _, extra = entry
    return words + (" (again)" if extra else "")


def _card(priority: int, card: Card) -> str:
    lines = [
        '<section class="card">',
        f"<h2><span>Priority {priority}</span> <small>importance {float(card['objective']):.3g}</small></h2>",
    ]
    shown = picture_files(card["files"])
    if shown:
        lines.append('<div class="views">')
        for key, path in shown:
            caption = CAPTIONS.get(key, key.replace("_", " "))
            kind = "face painted" if key == PAINTED else "face"
            picture = f'<img src="{escape(path)}" alt="expression {priority}, {escape(caption)}">'
            caption = f"<figcaption>{escape(caption)}</figcaption>"
            lines.append(f'<figure><div class="{kind}">{picture}</div>{caption}</figure>')
        lines.append("</div>")
    lines.append("<ul>")
    for entry in card["legend"]:
        _, name, colour, extra = entry
        rgb = ",".join(str(int(round(255 * float(c)))) for c in np.asarray(colour).ravel()[:3])
        style = ' class="extra"' if extra else ""
        lines.append(
            f'<li{style} title="{escape(name)}"><span class="swatch" style="background: rgb({rgb})"></span>'
            f"{escape(_shape_text(entry))}</li>"
        )
    lines += ["</ul>", "</section>"]
    return "\n".join(lines)
