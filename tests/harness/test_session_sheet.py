"""``session.html`` prints on A4 and on US Letter: the overview (every expression's card on one page, no text
under 7 pt), then the session, one expression per half page with its bare pose at least 60 mm tall, then
the TD's page. The actor's pages speak the actor's words (what to do, in order); the TD's page says what
packing did in plain sentences; every picture links to its full-size PNG; on screen the sheet uses the
window."""

from __future__ import annotations

import html
import json
import re
from pathlib import Path

import pytest

import rigs
from session._files import session_files
from session._notes import plain_note, td_notes
from session._sheet import INSTRUCTIONS, sheet_layout, take_layout
from session._words import plain_words
from tests.chromium import run_chromium

#: Paper sizes in millimetres (width, height) and their PDF media boxes in points.
PAPERS = {"A4": ((210.0, 297.0), (595, 842)), "letter": ((215.9, 279.4), (612, 792))}
MARGIN = 10.0
MILLIMETRE = 96 / 25.4  # CSS pixels
NOTES = (
    "2 mirror matches overlap on more than 15% of their active vertices away from the symmetry axis and "
    "are not paired (they spread over both halves, sec. 4.4.1): jawLeft+jawRight (59%), "
    "mouthLeft+mouthRight (67%)",
    "motion symmetry skipped region pairs upper_lip/lower_lip, upper_eyelid_L/lower_eyelid_L: rig has no "
    "such regions",
    "no target neutral: triangle distortion (eqs. 6-7) is 0",
    "face.glb: mesh 'head' primitive 0 NORMAL: compressed with EXT_meshopt_compression (filter "
    "OCTAHEDRAL); NORMAL left out",
)
CONSTRAINTS = {
    "default": True,
    "rules": [
        {"rule": "gaze-conjugate", "kind": "together", "shapes": ["eyeLookOutLeft", "eyeLookInRight"]},
        {"rule": "lid-hides-eye", "kind": "apart", "shapes": ["eyeBlinkLeft", "eyeLookUpLeft"]},
    ],
    "notes": [],
}
#: Words that are the TD's (packing's parameters, rule identifiers, the files' names), never the actor's.
JARGON = re.compile(
    r"\bmu\b|threshold|importance|priority|gaze-conjugate|lid-hides-eye|mirror match|EXT_meshopt|NORMAL|"
    r"expressions\.json|blendshape|\bsec\.|\beqs?\.",
    re.IGNORECASE,
)

# Injected before </body> of a copy of the sheet: measures the overview, the cards, the takes and their
# pictures and the type once the page has loaded, and writes the measures into the DOM, where --dump-dom
# shows them.
PROBE = """<script>
window.addEventListener("load", () => {
  const body = document.body.getBoundingClientRect();
  const box = e => e.getBoundingClientRect();
  const cards = [...document.querySelectorAll(".card")].map(card => ({
    left: box(card).left - body.left, right: box(card).right - body.left,
    overflow: card.scrollWidth - card.clientWidth,
    heading: box(card.querySelector("h2")).height,
    headingLine: parseFloat(getComputedStyle(card.querySelector("h2")).lineHeight)}));
  const takes = [...document.querySelectorAll(".take")].map(take => ({
    height: box(take).height, overflow: take.scrollHeight - take.clientHeight,
    poses: [...take.querySelectorAll(".pose img")].map(img => box(img).height),
    right: box(take).right - body.left}));
  const worded = [...document.body.querySelectorAll("*")].filter(
    e => [...e.childNodes].some(n => n.nodeType === 3 && n.textContent.trim()));
  const sizes = worded.map(e => parseFloat(getComputedStyle(e).fontSize));
  const probe = document.createElement("pre");
  probe.id = "probe";
  probe.textContent = JSON.stringify({
    width: body.width, overview: box(document.querySelector(".overview")).height, cards, takes,
    smallest: Math.min(...sizes), images: [...document.images].map(i => i.naturalWidth)});
  document.body.appendChild(probe);
});
</script>"""


@pytest.fixture(scope="module")
def seven_columns(tmp_path_factory) -> Path:
    """The session files of sixteen one-shape expressions of the generated ARKit rig (four of them gazes):
    an overview of four columns or more."""
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
        "excluded": [
            {
                "shape": "mouthClose",
                "reason": "left out by the default constraints: scanned only with jawOpen (rule "
                "mouthClose-corrective)",
            }
        ],
        "constraints": CONSTRAINTS,
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


def probe(folder: Path, sheet: str, paper: str, profile: Path) -> dict:
    """The probe's measures of ``sheet`` laid out as wide as ``paper`` holds inside its margins."""
    (width, _), _ = PAPERS[paper]
    measured = folder / f"measure-{paper}.html"
    style = f"<style>body {{ width: {width - 2 * MARGIN}mm; padding: 0; }}</style>"
    measured.write_text(sheet.replace("</head>", style + "</head>").replace("</body>", PROBE + "</body>"))
    dump = run_chromium(measured, profile, "--virtual-time-budget=5000", "--dump-dom")
    return json.loads(html.unescape(re.search(r'<pre id="probe">(.*?)</pre>', dump, re.S).group(1)))


@pytest.mark.parametrize("paper", sorted(PAPERS))
def test_the_sheet_prints_the_overview_on_one_page_then_two_expressions_a_page(
    seven_columns, paper, tmp_path
) -> None:
    sheet = (seven_columns / "session.html").read_text()
    assert columns_of(sheet) >= 4
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
    assert len(re.findall(rb"/Type\s*/Page\b", data)) == 1 + 16 // 2 + 1  # overview, takes, the TD's page

    measures = probe(seven_columns, sheet, paper, tmp_path / "profile")
    inside = (width - 2 * MARGIN, height - 2 * MARGIN)  # what the page holds inside its margins, in mm
    assert abs(measures["width"] - inside[0] * MILLIMETRE) < 1
    assert measures["overview"] <= inside[1] * MILLIMETRE  # every card on the first page
    for card in measures["cards"]:
        assert 0 <= card["left"] and card["right"] <= measures["width"] + 0.5  # no column clipped
        assert card["overflow"] <= 0  # nothing runs out of a card
        assert card["heading"] < 1.5 * card["headingLine"]  # "Expression N" on one line
    assert len(measures["cards"]) == len(measures["takes"]) == 16
    for take in measures["takes"]:
        assert 2 * take["height"] + 3 * MILLIMETRE <= inside[1] * MILLIMETRE  # two to a page
        assert take["overflow"] <= 0 and take["right"] <= measures["width"] + 0.5
        assert len(take["poses"]) == 2 and min(take["poses"]) >= 60 * MILLIMETRE  # the bare poses, large
    assert measures["smallest"] >= 7 * 96 / 72 - 0.01  # no text under 7 pt
    assert len(measures["images"]) == 16 * 6 and min(measures["images"]) > 0  # every picture loaded


def test_on_screen_the_sheet_uses_the_window(seven_columns, tmp_path) -> None:
    sheet = (seven_columns / "session.html").read_text()
    assert "max-width: 190mm" not in sheet
    page = seven_columns / "screen.html"
    page.write_text(sheet.replace("</body>", PROBE + "</body>"))
    dump = run_chromium(
        page, tmp_path / "profile", "--window-size=1600,900", "--virtual-time-budget=5000", "--dump-dom"
    )
    measures = json.loads(html.unescape(re.search(r'<pre id="probe">(.*?)</pre>', dump, re.S).group(1)))
    assert measures["width"] > 1500  # not 190 mm (718 px)


def test_every_picture_links_to_its_full_size_png(seven_columns) -> None:
    sheet = (seven_columns / "session.html").read_text()
    linked = re.findall(r'<a href="([^"]+)"><div class="[^"]+"><img src="([^"]+)"', sheet)
    assert len(linked) == sheet.count("<img ") == 16 * 6
    assert all(href == src and (seven_columns / src).is_file() for href, src in linked)


def test_each_card_shows_its_three_pictures_captioned_and_its_steps(seven_columns) -> None:
    sheet = (seven_columns / "session.html").read_text()
    document = json.loads((seven_columns / "expressions.json").read_text())
    overview = sheet.split('<section class="session">')[0]
    first = overview.split("<h2>Expression 1</h2>")[1].split("<h2>Expression 2</h2>")[0]
    files = document["expressions"][0]["files"]
    shown = re.findall(r'<img src="([^"]+)"[^>]*></div></a><figcaption>([^<]+)</figcaption>', first)
    assert shown == [
        (files["front"], "what moves"),
        (files["front_pose"], "front"),
        (files["three_quarter_pose"], "\u00be view"),
    ]
    assert "Close your left eye</li>" in first  # eyeBlinkLeft, in the actor's words


def test_the_actors_pages_speak_the_actors_words_and_the_tds_page_plain_sentences(seven_columns) -> None:
    sheet = (seven_columns / "session.html").read_text()
    body = sheet.split("</style>")[1]
    actors, tds = body.split('<section class="notes">')
    text = re.sub(r"<[^>]+>", " ", re.sub(r' (title|alt|src|href|style)="[^"]*"', "", actors))
    assert not JARGON.search(html.unescape(text)), JARGON.search(html.unescape(text))
    assert html.escape(INSTRUCTIONS) in actors and "Arrows on the eyes show where to look" in actors
    assert "Look down" in actors and "Look to your right" in actors  # eyeLookDownLeft, eyeLookInLeft
    notes = [html.unescape(p) for p in re.findall(r"<p>(.*?)</p>", tds)]
    assert "1 shape is in no expression: mouthClose (scanned only with jawOpen)." in notes
    assert any(
        note.startswith("2 left/right pairs are scanned apart") and "jawLeft and jawRight" in note
        for note in notes
    )
    assert any("both eyes look the same way" in note for note in notes)
    assert any("EXT_meshopt_compression" in note for note in notes)  # the decoder's warning: the TD's only
    for note in notes:
        assert (note[:1].isupper() or note[:1].isdigit()) and note.endswith(".")
        assert not re.search(r"gaze-conjugate|lid-hides-eye|\(rule |\bsec\.|\beqs?\.", note), note


def test_gaze_shapes_carry_an_arrow_where_the_eye_turns(seven_columns) -> None:
    import numpy as np
    from PIL import Image

    document = json.loads((seven_columns / "expressions.json").read_text())
    for expression in document["expressions"]:
        gaze = expression["shapes"][0].startswith("eyeLook")
        for key in ("front", "front_pose", "three_quarter_pose"):
            pixels = np.asarray(Image.open(seven_columns / expression["files"][key]).convert("L"))
            face = pixels[:, : pixels.shape[1] if key != "front" else int(0.62 * pixels.shape[1])]
            assert ((face < 20).sum() > 30) == gaze, (expression["shapes"], key)  # the arrow's black


def test_plain_notes_drop_every_reference_to_the_paper() -> None:
    assert plain_note("a (eq. 2) b") == "a b"
    assert plain_note("weights (eq. 4, importance)") == "weights"
    assert plain_note("pairs (sec. 4.4) kept") == "pairs kept"
    assert plain_note("as eqs. 9-12 find") == "as find"
    assert plain_note("no reference here (3 shapes)") == "no reference here (3 shapes)"


def test_td_notes_count_in_words_and_keep_unknown_notes_as_sentences() -> None:
    document = {
        "solver": "greedy",
        "params": {"mu": 0.25, "symmetry": True},
        "expressions": [{"shapes": ["a"]}],
        "constraints": {"default": False, "rules": [], "notes": []},
        "excluded": [
            {"shape": "b", "reason": "left out by --exclude"},
            {"shape": "c", "reason": "left out by --exclude"},
        ],
    }
    notes = td_notes(
        document, ["1 symmetry pair kept together (1 mirror, 0 motion)", "something odd (sec. 4.2)"]
    )
    assert notes[0].startswith("The 1 expression was chosen by greedy") and "25%" in notes[0]
    assert notes[1] == "The face rules were off (--no-default-constraints)."
    assert notes[2] == "2 shapes are in no expression: b, c (left out by --exclude)."
    assert notes[3].startswith("1 pair of shapes is always scanned together")
    assert notes[4] == "Something odd."


def test_left_and_right_are_the_actors() -> None:
    assert plain_words("eyeBlinkLeft") == "left eye blink"  # ARKit: the actor's left eye
    assert plain_words("jawLeft") == "jaw to the actor's left"
    assert plain_words("mouthRight") == "mouth to the actor's right"


def test_the_layout_keeps_cards_readable_and_pictures_large_enough() -> None:
    few = sheet_layout([["Open your jaw wide"]], 3, 0.65)
    assert few.columns == 1 and few.picture > 60
    many = sheet_layout([["Raise your upper lip, showing the upper teeth"] * 2] * 60, 3, 0.65)
    assert many.columns <= 8 and many.picture >= 14  # more pages rather than unreadable cards
    assert sheet_layout([["a"]] * 8, 0, 0.65).columns == 1  # no pictures: the widest cards that fit
    assert 2 <= sheet_layout([["a"]] * 40, 0, 0.65).columns <= 4


def test_a_take_with_many_steps_takes_a_whole_page_with_larger_poses() -> None:
    half, whole = (
        take_layout(["Open your jaw wide"] * 3, 0.65),
        take_layout(["Smile with both corners"] * 30, 0.65),
    )
    assert not half.whole and whole.whole and 60 <= half.pose < whole.pose


def test_one_shape_left_out_is_said_in_the_singular() -> None:
    from session._constraints import session_constraints

    notes = session_constraints(rigs.generate("arkit52"), {}).notes
    assert any(note.startswith("1 shape left out of the session: mouthClose") for note in notes), notes
