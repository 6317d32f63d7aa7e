"""``session.html``: the scan sheet of a scanning session, for the screen and for print.

It is made for two readers. The actor's pages come first, in the actor's words (`session._actor`): an
overview of every expression on one page (one card each, in priority order: the sequence order of
Algorithm 1, most important first, Carrigan et al. 2020, sec. 4.5), then the session itself, one expression
per half page (`take_layout`) with the bare pose large enough to match (the front and the three-quarter
view, each at least `_SMALLEST_POSE` mm tall on paper), the steps to do in order, each with the colour of
what it moves in the coloured picture. The TD's page comes last: how the expressions were chosen, the face
rules, what is in no expression and what packing noticed, each a plain sentence (`session._notes`), the
identifiers left to ``expressions.json``.

The page needs nothing but the pictures beside it (no script, no web font); every picture links to its
full-size PNG. On screen it uses the window's width. It prints on A4 and on US Letter alike: the layouts are
made for the part of the page both papers have inside 10 mm margins (`_PAGE`), the overview's columns
shrink with the page (``minmax(0, 1fr)``), no text is smaller than 7 pt, nothing breaks across pages, and
the session and the TD's page start on pages of their own.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from html import escape
from typing import Any, TypedDict

import numpy as np

from session._actor import Step, actor_steps, is_gaze
from session._notes import td_notes
from session._picture_set import FACE_SHARE, PAINTED, POSES, SIZE, Legend, face_size, picture_files


class Card(TypedDict):
    """One expression of the scan sheet: its ``files`` (``expressions.json``'s, relative paths of its
    pictures among them), its importance (``objective``, eq. 3a) and its `Legend`."""

    files: Mapping[str, str]
    objective: float
    legend: Legend


#: What the actor is told, before the cards.
INSTRUCTIONS = (
    "Do the expressions in order, 1 first. For each, do every step at once and hold still: match the grey "
    "pictures; the coloured one shows what each step moves. Left and right are your own: your left is on "
    "the right of a front picture, and the three-quarter view shows your left side. A step marked "
    "\u201cagain\u201d repeats one scanned before, in another combination."
)
#: Said besides when an expression has a gaze.
GAZE = "Arrows on the eyes show where to look."
#: Captions of the pictures, by their key in an expression's ``files``.
CAPTIONS = {PAINTED: "what moves", "front_pose": "front", "three_quarter_pose": "\u00be view"}

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
#: The narrowest a card's inside may be (mm): its heading, "Expression 88" in 8 pt bold.
_NARROWEST = 24.0
#: The session's pages: a take (one expression) is half the page's height (mm, with the gap between two)
#: or, when its steps do not fit beside its pictures, the whole page; its type is `_STEP` points.
_TAKE, _TAKE_GAP, _TAKE_PADDING, _STEP = (_PAGE[1] - _SPARE - 3.0) / 2, 3.0, 2.0, 9.0
#: The bare pose on paper is at least this tall (mm), and the coloured picture beside the steps this tall.
_SMALLEST_POSE, _PAINTED = 60.0, 36.0

_STYLE = """
@page { margin: 10mm; }
* { box-sizing: border-box; }
html { -webkit-print-color-adjust: exact; print-color-adjust: exact; }
body { font: 8pt/1.25 "DejaVu Sans", Arial, sans-serif; color: #111; background: #fff; margin: 0;
       padding: 4mm; }
@media print { body { padding: 0; } }
a { color: inherit; }
a img { border: 0; }
figure a { display: block; }
header h1 { font-size: 12pt; margin: 0 0 1mm; }
header p { font-size: 7.5pt; color: #222; margin: 0 0 1.5mm; }
.grid { display: grid; grid-template-columns: repeat(var(--columns), minmax(0, 1fr)); gap: 2mm; }
.card { border: 0.25mm solid #888; border-radius: 1mm; padding: 1.25mm; break-inside: avoid;
        page-break-inside: avoid; min-width: 0; }
.card h2 { font-size: 8pt; line-height: 1.25; margin: 0 0 0.6mm; white-space: nowrap; }
.views { display: grid; grid-template-columns: repeat(var(--per-row), minmax(0, 1fr)); gap: 0.8mm; }
figure { margin: 0; min-width: 0; text-align: center; }
.face { overflow: hidden; height: var(--face-height); width: calc(var(--face-height) * var(--face-aspect));
        max-width: 100%; margin: 0 auto; }
.face img { display: block; height: 100%; width: auto; }
.face.painted img { width: var(--face-zoom); height: auto; }
figcaption { font-size: 7pt; color: #444; white-space: nowrap; overflow: hidden; text-overflow: clip; }
.steps { list-style: none; margin: 0.6mm 0 0; padding: 0; font-size: 7pt; line-height: 1.25; }
.steps li { padding-left: var(--indent); text-indent: calc(-1 * var(--indent)); overflow-wrap: anywhere; }
.swatch { display: inline-block; width: 0.75em; height: 0.75em; margin-right: 0.3em; vertical-align: -0.05em;
          border: 0.1mm solid #0003; text-indent: 0; }
.again { color: #555; font-style: italic; }
.session { break-before: page; page-break-before: always; }
.take { height: var(--take); margin-bottom: 3mm; border: 0.25mm solid #888; border-radius: 1mm;
        padding: 2mm; break-inside: avoid; page-break-inside: avoid; display: flex; flex-direction: column;
        overflow: hidden; }
.take h2 { font-size: 11pt; margin: 0 0 1.5mm; }
.take h2 small { font-weight: normal; color: #444; font-size: 9pt; }
.take .body { display: flex; gap: 2mm; min-height: 0; }
.take.whole .body { flex-wrap: wrap; }
.take .pose .face { height: var(--pose-height); width: calc(var(--pose-height) * var(--face-aspect)); }
.take .do { flex: 1 1 0; min-width: 45mm; }
.take.whole .do { flex-basis: 100%; display: flex; gap: 3mm; }
.take ol { margin: 0 0 2mm; padding-left: 1.6em; font-size: 9pt; line-height: 1.3; }
.take ol li { margin-bottom: 0.8mm; }
.take .do .face { height: var(--painted-height); width: calc(var(--painted-height) * var(--face-aspect));
                 margin: 0; }
.take .do figure { text-align: left; }
.notes { break-before: page; page-break-before: always; font-size: 8pt; }
.notes h2 { font-size: 11pt; margin: 0 0 2mm; }
.notes p { margin: 0 0 1.5mm; }
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
        The text lines of each card (its steps).
    pictures : int
        Pictures per card.
    aspect : float
        A picture's width over its height.
    header : sequence of str
        Paragraphs above the cards (7.5 pt, across the page).
    """
    width, height = _PAGE[0], _PAGE[1] - _SPARE
    fixed = _TITLE * _LINE + sum(_lines(text, width, 7.5) * 7.5 * _LINE + 1.5 for text in header)
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
    """Height (mm) of a card's heading and step lines (after two swatches) at ``inner`` millimetres wide."""
    steps = sum(_lines(line, inner - 2.1 * _TEXT * 0.3528, _TEXT) for line in lines)
    return _HEADING * _LINE + 0.6 + steps * _TEXT * _LINE + 0.6


@dataclass(frozen=True)
class TakeLayout:
    """An expression of the session's pages: half a page (``whole`` False, the steps beside the poses) or a
    whole page (the steps below them), and the height (mm) of its pose pictures."""

    whole: bool
    pose: float

    @property
    def height(self) -> float:
        """The take's height on paper (mm)."""
        return 2 * _TAKE + _TAKE_GAP if self.whole else _TAKE


def take_layout(steps: Sequence[str], aspect: float) -> TakeLayout:
    """Half a page when the ``steps`` (and the coloured picture below them) fit beside the two pose
    pictures (of width over height ``aspect``), as tall as a column of steps at least 48 mm wide allows;
    else a whole page with the poses across it.

    Examples
    --------
    >>> take_layout(["Open your jaw wide"], 0.65).whole, take_layout(["Smile"] * 40, 0.65).whole
    (False, True)
    >>> take_layout(["Open your jaw wide"], 0.65).pose >= _SMALLEST_POSE
    True
    """
    inside = _PAGE[0] - 2 * _TAKE_PADDING
    above = 2 * _TAKE_PADDING + 11.0 * _LINE + 1.5 + _TEXT * _LINE + 4.0  # padding, heading, caption
    column = 48.0
    pose = min(_TAKE - above, (inside - column - 2 * _GAP) / (2 * aspect))
    column = inside - 2 * pose * aspect - 2 * _GAP
    text = sum(_lines(step, column - 6.0, _STEP) * _STEP * 0.3528 * 1.3 + 0.8 for step in steps)
    if pose >= _SMALLEST_POSE and text + _PAINTED + _TEXT * _LINE + 2.0 <= _TAKE - above + _TEXT * _LINE:
        return TakeLayout(False, round(pose, 1))
    return TakeLayout(
        True, round(min(2 * _TAKE + _TAKE_GAP - above - 100.0, (inside - _GAP) / (2 * aspect)), 1)
    )


def scan_sheet(
    document: Mapping[str, Any], cards: Sequence[Card], *, title: str, notes: Sequence[str] = ()
) -> str:
    """The HTML text of the scan sheet.

    Parameters
    ----------
    document : mapping
        ``expressions.json`` (its solver, parameters, constraints and left-out shapes are said on the
        TD's page).
    cards : sequence of Card
        Per expression, in priority order.
    title : str
        The rig's name.
    notes : sequence of str
        What packing noted and warned, for the TD's page (`session._notes.td_notes`).
    """
    steps = [_card_steps(card) for card in cards]
    texts = [[_step_text(step) for step in card_steps] for card_steps in steps]
    shown = max((len(picture_files(card["files"])) for card in cards), default=0)
    gaze = any(is_gaze(entry[1]) for card in cards for entry in card["legend"])
    told = [_summary(document, len(cards)), INSTRUCTIONS + (" " + GAZE if gaze else "")]
    aspect = FACE_SHARE * SIZE[0] / SIZE[1]
    layout = sheet_layout(texts, shown, aspect, header=told)
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
        '<section class="overview">',
        "<header>",
        f"<h1>Scan session: {escape(title)}</h1>",
        *(f"<p>{escape(paragraph)}</p>" for paragraph in told),
        "</header>",
        '<main class="grid">',
        *(
            _card(number, card, card_steps)
            for number, (card, card_steps) in enumerate(zip(cards, steps, strict=True), 1)
        ),
        "</main>",
        "</section>",
    ]
    pose_aspect = face_size()[0] / face_size()[1]
    if cards:
        parts.append('<section class="session">')
        for number, (card, card_steps) in enumerate(zip(cards, steps, strict=True), start=1):
            take = take_layout([step.text for step in card_steps], pose_aspect)
            parts.append(_take(number, len(cards), card, card_steps, take))
        parts.append("</section>")
    parts.append('<section class="notes">')
    parts.append(f"<h2>For the TD: {escape(title)}</h2>")
    parts += [f"<p>{escape(sentence)}</p>" for sentence in td_notes(document, notes)]
    parts += ["</section>", "</body>", "</html>", ""]
    return "\n".join(parts)


def _summary(document: Mapping[str, Any], count: int) -> str:
    shapes = sum(len(expression["shapes"]) for expression in document.get("expressions", []))
    return f"{count} expression{'s' * (count != 1)} covering {shapes} shape{'s' * (shapes != 1)}."


def _card_steps(card: Card) -> list[Step]:
    """The steps of a card's expression (`session._actor.actor_steps`)."""
    legend = card["legend"]
    return actor_steps(
        [name for _, name, _, extra in legend if not extra], [name for _, name, _, extra in legend if extra]
    )


def _step_text(step: Step) -> str:
    return step.text + (" (again)" if step.again else "")


def _steps_list(steps: Sequence[Step], colours: Mapping[str, np.ndarray], tag: str, kind: str) -> str:
    """The steps as an ``ol`` or ``ul``, each with a swatch of the colour of each of its shapes."""
    indent = 1.05 * max((len(step.shapes) for step in steps), default=1)
    lines = [f'<{tag} class="{kind}" style="--indent: {indent:.2f}em">']
    for step in steps:
        swatches = "".join(
            f'<span class="swatch" style="background: rgb({_rgb(colours[name])})"></span>'
            for name in step.shapes
        )
        again = ' class="again"' if step.again else ""
        names = escape(", ".join(step.shapes))
        lines.append(f'<li{again} title="{names}">{swatches}{escape(_step_text(step))}</li>')
    lines.append(f"</{tag}>")
    return "\n".join(lines)


def _rgb(colour: np.ndarray) -> str:
    return ",".join(str(int(round(255 * float(c)))) for c in np.asarray(colour).ravel()[:3])


def _picture(key: str, path: str, number: int, kind: str) -> str:
    """A captioned picture that links to its full-size PNG."""
    caption = CAPTIONS.get(key, key.replace("_", " "))
    image = f'<img src="{escape(path)}" alt="expression {number}, {escape(caption)}">'
    return (
        f'<figure class="{escape(key)}-view"><a href="{escape(path)}"><div class="{kind}">{image}</div></a>'
        f"<figcaption>{escape(caption)}</figcaption></figure>"
    )


def _card(number: int, card: Card, steps: Sequence[Step]) -> str:
    lines = ['<section class="card">', f"<h2>Expression {number}</h2>"]
    shown = picture_files(card["files"])
    if shown:
        lines.append('<div class="views">')
        lines += [
            _picture(key, path, number, "face painted" if key == PAINTED else "face") for key, path in shown
        ]
        lines.append("</div>")
    colours = {name: colour for _, name, colour, _ in card["legend"]}
    lines += [_steps_list(steps, colours, "ul", "steps"), "</section>"]
    return "\n".join(lines)


def _take(number: int, count: int, card: Card, steps: Sequence[Step], layout: TakeLayout) -> str:
    """One expression of the session's pages: its poses large, its steps in order and what each moves."""
    files = card["files"]
    style = (
        f"--take: {layout.height:.1f}mm; --pose-height: {layout.pose:.1f}mm; --painted-height: {_PAINTED}mm"
    )
    lines = [
        f'<article class="take{" whole" if layout.whole else ""}" style="{style}">',
        f"<h2>Expression {number} <small>of {count}</small></h2>",
        '<div class="body">',
    ]
    lines += [
        f'<div class="pose">{_picture(key, files[key], number, "face")}</div>'
        for key in POSES
        if key in files
    ]
    colours = {name: colour for _, name, colour, _ in card["legend"]}
    lines.append('<div class="do">')
    lines.append(_steps_list(steps, colours, "ol", "take-steps"))
    if PAINTED in files:
        lines.append(_picture(PAINTED, files[PAINTED], number, "face painted"))
    lines += ["</div>", "</div>", "</article>"]
    return "\n".join(lines)
