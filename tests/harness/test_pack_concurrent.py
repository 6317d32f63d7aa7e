"""Two commands writing one output folder at once: the second is refused with one line while the first
holds the folder (new or not), and the folder never mixes the two."""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from registry import OutputFolderError, claim
from registry._outdir import MANIFEST_NAME
from tests.harness.cli_helpers import assert_one_line_error, invoke

#: Bound on each pack of the race (seconds).
PATIENCE = 120.0


def _files(folder: Path) -> dict[str, str]:
    return {
        path.relative_to(folder).as_posix(): hashlib.sha256(path.read_bytes()).hexdigest()
        for path in folder.rglob("*")
        if path.is_file() and path.name != MANIFEST_NAME
    }


def test_a_claimed_folder_is_refused_to_a_second_claim_until_the_first_closes(tmp_path) -> None:
    out = tmp_path / "new" / "session"
    first = claim(out, kind="pack", force=False, lock=True)
    with pytest.raises(OutputFolderError, match="in use by another harness command"):
        claim(out, kind="pack", force=True, lock=True)
    first.replace({"expression_01.obj": "v 0 0 0\n", "pictures/front.png": b"png"})
    first.close()
    with pytest.raises(OutputFolderError, match="holds a harness pack"):
        claim(out, kind="pack", force=False, lock=True)
    with claim(out, kind="pack", force=True, lock=True) as again:
        assert set(again.files) == {"expression_01.obj", "pictures/front.png"}


def test_the_files_a_claim_is_writing_survive_a_second_claim(tmp_path) -> None:
    out = tmp_path / "session"
    writing = claim(out, kind="pack", force=False, lock=True)

    def contents():
        yield "expression_01.obj", "v 0 0 0\n"
        with pytest.raises(OutputFolderError, match="in use"):  # would remove the new folder as a leftover
            claim(out, kind="pack", force=True, lock=True)
        yield "expression_02.obj", "v 1 0 0\n"

    writing.replace(contents())
    writing.close()
    assert set(_files(out)) == {"expression_01.obj", "expression_02.obj"}


def test_a_pack_into_a_folder_another_command_holds_is_one_line(tmp_path) -> None:
    out = tmp_path / "session"
    with claim(out, kind="pack", force=False, lock=True):
        result = invoke("pack", "tiny", "--solver", "greedy", "--no-pictures", "--out", out)
        assert_one_line_error(result, f"{out}: in use by another harness command")
    assert list(out.iterdir()) == []
    done = invoke("pack", "tiny", "--solver", "greedy", "--no-pictures", "--out", out)
    assert done.exit_code == 0, done.output


def test_two_packs_started_together_into_one_new_folder_never_mix(tmp_path) -> None:
    out = tmp_path / "session"
    command = [sys.executable, "-c", "from harness.cli import main; main()", "pack", "tiny"]
    processes = [
        subprocess.Popen(
            [*command, "--solver", "greedy", "--seed", str(seed), "--out", str(out)],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
            env={**os.environ, "COLUMNS": "250"},
        )
        for seed in (1, 2)
    ]
    errors = [process.communicate(timeout=PATIENCE)[1] for process in processes]
    codes = sorted(process.returncode for process in processes)
    assert codes == [0, 2], errors
    refused = errors[[process.returncode for process in processes].index(2)].strip()
    assert len(refused.splitlines()) == 1 and str(out) in refused, refused
    assert "in use by another harness command" in refused or "holds a harness pack" in refused, refused
    manifest = json.loads((out / MANIFEST_NAME).read_text())["files"]
    assert {name: entry["sha256"] for name, entry in manifest.items()} == _files(out)
    document = json.loads((out / "expressions.json").read_text())
    meshes = sorted(path.name for path in out.glob("expression_*.obj"))
    assert meshes == [f"expression_{number:02d}.obj" for number in range(1, len(document["expressions"]) + 1)]
