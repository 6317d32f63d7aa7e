"""``harness report`` beside ``harness pack``: a session folder is named as one (the report is for run
folders), and an earlier report is replaced only with ``--force``, as pack's session is."""

from __future__ import annotations

import json

from registry import claim
from tests.harness.cli_helpers import assert_one_line_error
from tests.harness.test_session_pack import invoke


def test_report_on_a_session_folder_says_it_is_one(tmp_path) -> None:
    out = tmp_path / "session"
    assert invoke("pack", "tiny", "--no-pictures", "--jmax", "2", "--out", out).exit_code == 0
    result = invoke("report", out)
    assert result.exit_code == 2, result.output
    assert "is a session folder of `harness pack`" in result.output
    assert "harness run --out" not in result.output
    assert not (out / "report").exists()


def test_an_earlier_report_is_replaced_only_with_force(tmp_path) -> None:
    run = tmp_path / "run"
    run.mkdir()
    (run / "run.json").write_text(json.dumps({"format": 1, "state": "complete", "config": {}}))
    claim(run / "report", kind="report", force=False).replace({"index.html": "<html>earlier</html>\n"})
    assert_one_line_error(invoke("report", run), "holds a harness report (index.html)", "--force")
    assert (run / "report" / "index.html").read_text() == "<html>earlier</html>\n"
    forced = invoke("report", run, "--force")  # claimed: on to the records, which this run lacks
    assert forced.exit_code == 2 and "holds a harness report" not in forced.output, forced.output
    (run / "report" / "notes.txt").write_text("the user's")
    assert_one_line_error(invoke("report", run, "--force"), "notes.txt")  # anything else: refused
