"""`harness report`: the Markdown and the self-contained HTML page, checked in headless Chromium."""

from __future__ import annotations

import html as html_module
import json
import re
import shutil
import subprocess
import time
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

import harness
import reports
from reports import build_report
from reports._document import CONTENT_SECURITY_POLICY, Image, Section, html_page
from reports.cli import report as report_command
from tests.chromium import FLAGS, chromium_binary

#: The committed run of the quick preset that CI compares against (``benchmarks/baseline``).
BASELINE = Path(__file__).resolve().parents[2] / "benchmarks" / "baseline"

# Injected first into <head> of a copy of the page: records failed images, error events, console errors and
# policy violations, and writes them into the DOM once the page has loaded, where --dump-dom shows them.
_PROBE = """<script nonce="probe">
window.__problems = [];
const describe = e => e.message || (e.target && e.target.outerHTML.slice(0, 80));
window.addEventListener("error", e => __problems.push("error: " + describe(e)), true);
window.addEventListener("securitypolicyviolation", e => __problems.push("blocked: " + e.blockedURI));
for (const level of ["error", "warn"]) {
  const original = console[level];
  console[level] = (...args) => { __problems.push(`console.${level}: ${args}`); original(...args); };
}
window.addEventListener("load", () => {
  const images = [...document.images].map(i => ({width: i.naturalWidth, complete: i.complete}));
  const probe = document.createElement("pre");
  probe.id = "probe";
  probe.textContent = JSON.stringify({images, problems: __problems});
  document.body.appendChild(probe);
});
</script>"""


@pytest.fixture(scope="module")
def chromium() -> str:
    """Path of the Chromium binary (`.ci/run` installs Debian's); the test skips without it."""
    return chromium_binary()


@pytest.fixture(scope="module")
def reported_run(tmp_path_factory, fabricate) -> Path:
    """A fabricated run (importance on and off, one solver skipped) and its report, built once."""
    run = fabricate(
        tmp_path_factory.mktemp("reported") / "run",
        importance=(True, False),
        skipped={"scip": "pyscipopt is not installed"},
    )
    build_report(run)
    return run


def test_report_writes_markdown_html_and_figures(reported_run):
    directory = reported_run / "report"
    markdown = (directory / "report.md").read_text()
    for heading in (
        "Timings per rig and solver (paper Table 2)",
        "Solvers across instances",
        "Agreement of chosen shapes (paper Table 3, its 'overlap')",
        "Coverage",
        "The paper's claims",
        "Transfer error (paper Figs. 9 and 10)",
        "Transfer error against the references",
        "Retargeted frames (Wagner et al. 2024, Fig. 10)",
        "Does the evaluation tell packings apart?",
        "Worst transferred shapes",
        "Expression counts",
        "Contact sheets",
        "Cells that did not finish",
    ):
        assert f"## {heading}" in markdown
    assert "| rig | warp | setting | solver | N | K |" in markdown
    assert "| face | alien | scip | 4 | skipped | pyscipopt is not installed |" in markdown
    assert "| claim | paper | measured | verdict |" in markdown
    claim = next(line for line in markdown.splitlines() if line.startswith("| optimal expressions transfer"))
    assert "cpsat against greedy: mean over 1 face" in claim
    assert "lower at 1 of 3 (seed, rig, warp, J)" in claim
    assert claim.endswith("| inconclusive |")  # one face: no interval
    assert "RMS divided by the dt RMS of the same cell and J" in markdown
    assert "The run has no delta transfer: no RMS relative to it." in markdown
    assert "The run judges no retargeted frames" in markdown
    assert "Training expressions: not recorded" in markdown  # the fabricated run.json has no config
    figures = sorted(path.name for path in (directory / "figures").iterdir())
    assert figures == [
        "contact-face-alien-importance-off.jpg",
        "contact-face-alien-importance-on.jpg",
        "coverage-face.png",
        "performance-profile.png",
        "rms-face.png",
        "solve-times.png",
    ]
    for name in figures:
        assert f"(figures/{name})" in markdown


def test_report_html_is_self_contained_and_deterministic(reported_run):
    run = reported_run
    page = (run / "report" / "index.html").read_text()
    assert CONTENT_SECURITY_POLICY in page
    assert not re.search(r"<script|<link|src=\"(?!data:image/(png|jpeg);base64,)", page)
    assert page.count('src="data:image/png;base64,') == 4  # plots as PNG
    assert page.count('src="data:image/jpeg;base64,') == 2  # the contact sheets' renders as JPEG
    # Every file the report writes is the same again, byte for byte; the folder's manifest names each by the
    # inode its new copy got, so it is compared without them.
    first, first_manifest = _written(run / "report")
    build_report(run)
    again, manifest = _written(run / "report")
    assert first == again and first_manifest == manifest


def _written(folder: Path) -> tuple[dict[str, bytes], dict]:
    """A report folder's files by name, and its manifest's entries without their inodes."""
    files = {path.name: path.read_bytes() for path in folder.rglob("*") if path.is_file()}
    manifest = json.loads(files.pop(".harness-manifest.json"))
    for entry in manifest["files"].values():
        entry.pop("inode")
    return files, manifest


def _chromium_flags(chromium: str, profile: Path) -> list[str]:
    return [chromium, *FLAGS, f"--user-data-dir={profile}", "--virtual-time-budget=5000"]


def _probe(chromium: str, page: Path, profile: Path) -> dict:
    """Load a copy of ``page`` with `_PROBE` in Chromium; return the images' states and the problems seen."""
    html = page.read_text().replace(
        CONTENT_SECURITY_POLICY, CONTENT_SECURITY_POLICY + "; script-src 'nonce-probe'"
    )
    probed = page.with_name("probed.html")
    probed.write_text(html.replace("<title>", _PROBE + "<title>", 1))
    dump = subprocess.run(
        [*_chromium_flags(chromium, profile), "--dump-dom", probed.as_uri()],
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    ).stdout
    probed.unlink()
    return json.loads(html_module.unescape(re.search(r'<pre id="probe">(.*?)</pre>', dump, re.S).group(1)))


def test_the_chromium_probe_sees_broken_images_and_network_requests(chromium, tmp_path):
    page = tmp_path / "index.html"
    sections = [Section("Broken", [Image("ok", b"not a png", "broken")])]
    page.write_text(
        html_page("probe check", sections).replace("</body>", '<img src="https://a.invalid/x.png"></body>')
    )
    probe = _probe(chromium, page, tmp_path / "profile")
    assert [image["width"] for image in probe["images"]] == [0, 0]
    assert any(problem.startswith("blocked: https://a.invalid/x.png") for problem in probe["problems"])
    assert sum(problem.startswith("error: <img") for problem in probe["problems"]) == 2


def test_report_html_loads_in_headless_chromium(reported_run, chromium, tmp_path):
    page = reported_run / "report" / "index.html"
    probe = _probe(chromium, page, tmp_path / "profile")
    assert probe["problems"] == []
    assert len(probe["images"]) == 6
    assert all(image["complete"] and image["width"] > 0 for image in probe["images"]), probe["images"]

    screenshot = tmp_path / "report.png"
    subprocess.run(
        [
            *_chromium_flags(chromium, tmp_path / "profile"),
            "--window-size=1400,3000",
            f"--screenshot={screenshot}",
            page.as_uri(),
        ],
        capture_output=True,
        timeout=120,
        check=True,
    )
    assert screenshot.stat().st_size > 10_000
    print(f"report screenshot: {screenshot}")


def test_report_command_prints_where_the_report_is(make_run, tmp_path):
    run = make_run("run")
    result = CliRunner().invoke(report_command, [str(run), "--expressions", "2"])
    assert result.exit_code == 0, result.output
    assert f"report: {run / 'report' / 'index.html'}" in result.output
    result = CliRunner().invoke(report_command, [str(tmp_path / "nothing")])
    assert result.exit_code == 2
    assert "no run.json here" in result.output and "Run `harness run --out" in result.output


def test_the_quick_preset_report_loads_in_headless_chromium(chromium, tmp_path):
    """The committed baseline is a real `harness run --preset quick`: its report must render completely."""
    run = shutil.copytree(BASELINE, tmp_path / "quick", ignore=shutil.ignore_patterns("report"))
    started = time.perf_counter()
    page, _ = build_report(run)
    print(f"quick preset report built in {time.perf_counter() - started:.1f} s: {page}")
    probe = _probe(chromium, page, tmp_path / "profile")
    assert probe["problems"] == []
    rigs_run = set(harness.read_records(run)["rig"])
    # coverage, RMS and a contact sheet per rig; the solvers' performance profile and time distribution
    assert len(probe["images"]) == 3 * len(rigs_run) + 2
    assert all(image["complete"] and image["width"] > 0 for image in probe["images"]), probe["images"]


def test_a_run_where_nothing_finished_still_gets_a_report(make_run):
    run = make_run("run", sequences={}, seconds={}, skipped={"highs": "highspy is not installed"})
    _, text = build_report(run)
    markdown = text.read_text()
    assert "No finished expressions." in markdown and "The run has no transfer records." in markdown
    assert "| face | alien | highs | 2 | skipped | highspy is not installed |" in markdown


def test_a_rig_that_cannot_be_rebuilt_gets_a_note_instead_of_a_contact_sheet(make_run, tmp_path):
    run = make_run("run", rig=str(tmp_path / "moved-away.npz"))
    _, text = build_report(run)
    assert "No contact sheet for rig moved-away: it could not be rebuilt (unknown rig" in text.read_text()


def test_the_agreement_of_solvers_is_counted_from_the_records(make_run, expected_agreement):
    run = make_run("run")
    expected = pd.DataFrame(expected_agreement[run])
    found = reports.agreement_counts(harness.read_records(run))
    assert list(found.columns) == list(reports.AGREEMENT_COLUMNS) and len(found) == len(expected) > 0
    key = ["solver_a", "solver_b", "first", "importance", "repetition"]
    columns = [*key, "expressions_a", "expressions_b", "shapes_a", "shapes_b", "shared"]
    ordered = [frame[columns].sort_values(key).reset_index(drop=True) for frame in (found, expected)]
    assert ordered[0].astype(str).equals(ordered[1].astype(str))
    _, text = build_report(run)
    assert "## Agreement of chosen shapes" in text.read_text()


def test_an_interrupted_run_says_how_many_of_its_cells_never_ran(make_run):
    run = make_run("run")
    info = json.loads((run / "run.json").read_text())
    recorded = len(harness.read_records(run).query("kind == 'cell'"))
    info.update(state="interrupted", n_cells=recorded + 3)
    (run / "run.json").write_text(json.dumps(info))
    _, text = build_report(run)
    assert f"; 3 of the grid's {recorded + 3} not run (resume the run)" in text.read_text()


def test_a_report_of_a_run_going_on_says_its_cells_are_still_to_come(make_run):
    """While a run holds its folder (its lock), its missing cells are on their way, not to be resumed."""
    import fcntl
    import os

    run = make_run("live")
    info = json.loads((run / "run.json").read_text())
    recorded = len(harness.read_records(run).query("kind == 'cell'"))
    info.update(state="running", n_cells=recorded + 3, finished=None)
    (run / "run.json").write_text(json.dumps(info))
    descriptor = os.open(run, os.O_RDONLY | os.O_DIRECTORY)
    try:
        fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)  # as the running harness holds it
        assert harness.in_progress(run)
        _, text = build_report(run)
    finally:
        os.close(descriptor)
    assert not harness.in_progress(run)
    assert f"; 3 of the grid's {recorded + 3} still to come (running)" in text.read_text()
    assert "not finished yet." in text.read_text()


def test_the_report_opens_with_its_verdicts_and_folds_the_detail(reported_run):
    page = (reported_run / "report" / "index.html").read_text()
    headings = ("The paper&#x27;s claims", "Solvers across instances", "Coverage")
    order = [page.index(heading) for heading in headings]
    assert order == sorted(order) and order[0] < page.index("Timings per rig and solver")
    for folded in ("Timings per rig and solver", "Worst transferred shapes", "Contact sheets"):
        assert f"<details><summary>{folded}" in page


def test_the_report_prints_on_a4_without_losing_columns(reported_run, tmp_path):
    """Printed (A4, 12 mm margins: 186 mm of width), no table is wider than the page."""
    from tests.chromium import Browser

    browser = Browser(tmp_path / "profile")
    try:
        browser.call("Emulation.setEmulatedMedia", media="print")
        browser.call(
            "Emulation.setDeviceMetricsOverride", width=703, height=1000, deviceScaleFactor=1, mobile=False
        )
        browser.open((reported_run / "report" / "index.html").as_uri())
        widest = browser.evaluate(
            "Math.max(...Array.from(document.querySelectorAll('table')).map(t => t.scrollWidth))"
        )
        assert widest <= 703
        shown = browser.evaluate(
            "Array.from(document.querySelectorAll('details figure img'))"
            ".every(i => i.getBoundingClientRect().height > 0)"
        )
        assert shown  # folded on screen, printed whole
    finally:
        browser.close()
