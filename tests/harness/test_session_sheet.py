"""``session.html`` prints: on A4 and on US Letter, at seven columns and more, every card inside the page,
no text under 7 pt, each card's pictures (coloured, bare front, bare three-quarter) captioned in the page,
the footer in a TD's words, and left and right the actor's."""

from __future__ import annotations

import html
import json
import re
from pathlib import Path

import pytest

import rigs
from session._files import session_files
from session._sheet import INSTRUCTIONS, plain_note, sheet_layout
from session._words import plain_words
from tests.chromium import run_chromium

#: Paper sizes in millimetres (width, height) and their PDF media boxes in points.
PAPERS = {"A4": ((210.0, 297.0), (595, 842)), "letter": ((215.9, 279.4), (612, 792))}
MARGIN = 10.0
NOTES = (
    "2 mirror matches overlap on more than 15% of their active vertices away from the symmetry axis and "
    "are not paired (they spread over both halves, sec. 4.4.1): jawLeft+jawRight (59%), "
    "mouthLeft+mouthRight (67%)",
    "no target neutral: triangle distortion (eqs. 6-7) is 0",
)

# Injected before </body> of a copy of the sheet: measures the cards, the headings, the type and the
# pictures once the page has loaded, and writes the measures into the DOM, where --dump-dom shows them.
PROBE = """<script>
window.addEventListener("load", () => {
  const body = document.body.getBoundingClientRect();
  const cards = [...document.querySelectorAll(".card")].map(card => {
    const box = card.getBoundingClientRect();
    return {left: box.left - body.left, right: box.right - body.left, bottom: box.bottom - body.top,
            overflow: card.scrollWidth - card.clientWidth,
            heading: card.querySelector("h2 span").getBoundingClientRect().height,
            headingLine: parseFloat(getComputedStyle(card.querySelector("h2")).lineHeight)};
  });
  const worded = [...document.body.querySelectorAll("*")].filter(
    e => [...e.childNodes].some(n => n.nodeType === 3 && n.textContent.trim()));
  const sizes = worded.map(e => parseFloat(getComputedStyle(e).fontSize));
  const probe = document.createElement("pre");
  probe.id = "probe";
  probe.textContent = JSON.stringify({
    width: body.width, height: document.documentElement.scrollHeight, cards,
    smallest: Math.min(...sizes), images: [...document.images].map(i => i.naturalWidth)});
  document.body.appendChild(probe);
});
</script>"""


@pytest.fixture(scope="module")
def seven_columns(tmp_path_factory) -> Path:
    """The session files of sixteen one-shape expressions of the generated ARKit rig: a sheet of at least
    seven columns."""
    rig = rigs.generate("arkit52")
    names = [name for name in rig.names if "Left" in name or "jaw" in name][:16]
    document = {
        "rig": "arkit52",
        "solver": "cpsat",
        "params": {"mu": 0.3, "symmetry": False, "max_per_expression": 1},
        "pairs": [],
        "expressions": [
            {"shapes": [name], "extra_examples": [], "objective": 1.0 / (1 + k)}
            for k, name in enumerate(names)
        ],
    }
    out = tmp_path_factory.mktemp("sheet")
    for name, content in session_files(rig, document, notes=NOTES):
        path = out / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(content.encode() if isinstance(content, str) else content)
    (out / "expressions.json").write_text(json.dumps(document))
    return out


def columns_of(sheet: str) -> int:
    return int(re.search(r"--columns: (\d+);", sheet).group(1))


@pytest.mark.parametrize("paper", sorted(PAPERS))
def test_the_sheet_prints_every_card_inside_one_page(seven_columns, paper, tmp_path) -> None:
    sheet = (seven_columns / "session.html").read_text()
    assert columns_of(sheet) >= 7
    (width, height), media = PAPERS[paper]
    printed = seven_columns / f"print-{paper}.html"
    printed.write_text(sheet.replace("</head>", f"<style>@page {{ size: {paper}; }}</style></head>"))
    pdf = tmp_path / "sheet.pdf"
    run_chromium(printed, tmp_path / "profile", "--no-pdf-header-footer", f"--print-to-pdf={pdf}")
    data = pdf.read_bytes()
    boxes = {
        tuple(round(float(v)) for v in box)
        for box in re.findall(rb"/MediaBox\s*\[\s*0 0 ([\d.]+) ([\d.]+)", data)
    }
    assert boxes == {media}  # printed on the paper asked for
    assert len(re.findall(rb"/Type\s*/Page\b", data)) == 1

    inside = (width - 2 * MARGIN, height - 2 * MARGIN)  # what the page holds inside its margins, in mm
    measured = seven_columns / f"measure-{paper}.html"
    style = f"<style>body {{ width: {inside[0]}mm; max-width: none; }}</style>"
    measured.write_text(sheet.replace("</head>", style + "</head>").replace("</body>", PROBE + "</body>"))
    dump = run_chromium(measured, tmp_path / "profile", "--virtual-time-budget=5000", "--dump-dom")
    probe = json.loads(html.unescape(re.search(r'<pre id="probe">(.*?)</pre>', dump, re.S).group(1)))
    millimetre = 96 / 25.4
    assert abs(probe["width"] - inside[0] * millimetre) < 1
    assert probe["height"] <= inside[1] * millimetre  # the whole sheet on one page
    for card in probe["cards"]:
        assert 0 <= card["left"] and card["right"] <= probe["width"] + 0.5  # no column clipped
        assert card["overflow"] <= 0  # nothing runs out of a card
        assert card["heading"] < 1.5 * card["headingLine"]  # "Priority N" on one line of its own
    assert len(probe["cards"]) == 16
    assert probe["smallest"] >= 7 * 96 / 72 - 0.01  # no text under 7 pt
    assert len(probe["images"]) == 48 and min(probe["images"]) > 0  # every picture loaded


def test_each_card_shows_its_three_pictures_captioned_in_the_page(seven_columns) -> None:
    sheet = (seven_columns / "session.html").read_text()
    document = json.loads((seven_columns / "expressions.json").read_text())
    first = sheet.split("<span>Priority 1</span>")[1].split("<span>Priority 2</span>")[0]
    files = document["expressions"][0]["files"]
    shown = re.findall(r'<img src="([^"]+)"[^>]*></div><figcaption>([^<]+)</figcaption>', first)
    assert shown == [
        (files["front"], "shapes"),
        (files["front_pose"], "front"),
        (files["three_quarter_pose"], "\u00be view"),
    ]


def test_the_sheet_speaks_to_the_td_without_equations(seven_columns) -> None:
    sheet = (seven_columns / "session.html").read_text()
    footer = sheet.split("<footer>")[1]
    assert "they spread over both halves)" in footer and "triangle distortion is 0" in footer
    assert not re.search(r"\b(eqs?|sec|secs)\.\s*\d", sheet.split("</style>")[1])
    assert html.escape(INSTRUCTIONS) in sheet and "actor&#x27;s left is on the right" in sheet


def test_plain_notes_drop_every_reference_to_the_paper() -> None:
    assert plain_note("a (eq. 2) b") == "a b"
    assert plain_note("weights (eq. 4, importance)") == "weights"
    assert plain_note("pairs (sec. 4.4) kept") == "pairs kept"
    assert plain_note("as eqs. 9-12 find") == "as find"
    assert plain_note("no reference here (3 shapes)") == "no reference here (3 shapes)"


def test_left_and_right_are_the_actors() -> None:
    assert plain_words("eyeBlinkLeft") == "left eye blink"  # ARKit: the actor's left eye
    assert plain_words("jawLeft") == "jaw to the actor's left"
    assert plain_words("mouthRight") == "mouth to the actor's right"


def test_the_layout_keeps_cards_readable_and_pictures_large_enough() -> None:
    few = sheet_layout([["jaw open"]], 3, 0.65)
    assert few.columns == 1 and few.picture > 60
    many = sheet_layout([["left mouth upper up"] * 2] * 60, 3, 0.65)
    assert many.columns <= 8 and many.picture >= 14  # more pages rather than unreadable cards
    assert sheet_layout([["a"]] * 8, 0, 0.65).columns == 1  # no pictures: the widest cards that fit
    assert 2 <= sheet_layout([["a"]] * 40, 0, 0.65).columns <= 4
