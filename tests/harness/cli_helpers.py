"""Calling the `harness` command line in-process, for the command-line tests."""

from __future__ import annotations

import json
from pathlib import Path

from click.testing import CliRunner, Result

from harness.cli import cli

#: Terminal width of the invoked commands: wide enough that a table row or an error stays on one line.
COLUMNS = 250


def invoke(*arguments: object, input: str | None = None) -> Result:
    """Run ``harness ARGUMENTS`` (each turned into text) in-process, with ``input`` on stdin."""
    return CliRunner(env={"COLUMNS": str(COLUMNS)}).invoke(cli, [str(a) for a in arguments], input=input)


def flat(text: str) -> str:
    """Terminal output with line wrapping undone."""
    return " ".join(text.split())


def assert_one_line_error(result: Result, *fragments: str) -> None:
    """Exit code 2 and one line of output holding every fragment, with no traceback."""
    assert result.exit_code == 2, result.output
    text = result.output.strip()
    assert "Traceback" not in text and len(text.splitlines()) == 1, text
    for fragment in fragments:
        assert fragment in text, text


def pack(rig: object, out: Path, *extra: object, pictures: bool = True) -> tuple[dict, str]:
    """``harness pack RIG --solver cpsat --jmax 20 --out OUT EXTRA...``: its ``expressions.json`` and its
    flattened output; without ``pictures`` no images are rendered (``--no-pictures``)."""
    options = [] if pictures else ["--no-pictures"]
    result = invoke("pack", rig, "--solver", "cpsat", "--jmax", "20", *options, "--out", out, *extra)
    assert result.exit_code == 0, result.output
    return json.loads((out / "expressions.json").read_text()), flat(result.output)
