"""The README's solver plugin recipe works as written: its three files (the plugin, its tests, the
``pyproject.toml`` that distributes it), copied from the README into a folder, install into a fresh
environment, the harness lists the plugin there and its tests pass.

Nothing is fetched: the fresh environment sees this one's packages (the harness, pytest, pip and
setuptools) through a site directory, and the plugin is built without build isolation.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

from tests.plugin_distribution import OFFLINE_INSTALL, fresh_environment, run_in

README = Path(__file__).resolve().parents[2] / "README.md"
SECTION = "## Adding a solver plugin"
#: The README's code blocks of the recipe, in order, and the file each one is.
FILES = ("my_solver.py", "test_my_solver.py", "pyproject.toml")


def recipe_files() -> dict[str, str]:
    """The recipe's files as the README gives them (its first three code blocks, each introduced by its
    file name)."""
    text = README.read_text(encoding="utf-8")
    section = text[text.index(SECTION) :]
    section = section[: section.index("\n## ", len(SECTION))]
    blocks = re.findall(r"`([\w.]+)`[^`]*?:\n\n```\w+\n(.*?)```", section, re.S)
    found = dict(blocks[: len(FILES)])
    assert tuple(found) == FILES, f"the README's recipe names {tuple(found)}, not {FILES}"
    return found


@pytest.mark.skipif(sys.platform == "win32", reason="the fresh environment's layout is POSIX")
def test_the_readme_plugin_recipe_installs_lists_and_passes_its_checks(tmp_path: Path) -> None:
    source = tmp_path / "my-solver"
    source.mkdir()
    for name, text in recipe_files().items():
        (source / name).write_text(text)
    python = fresh_environment(tmp_path / "env")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    assert run_in(python, "-c", "import my_solver", cwd=elsewhere).returncode != 0  # not there before

    installed = run_in(python, *OFFLINE_INSTALL, str(source), cwd=elsewhere)
    assert installed.returncode == 0, installed.stderr[-3000:]

    listed = run_in(python, "-c", "from harness.cli import main; main()", "list", "--json", cwd=elsewhere)
    assert listed.returncode == 0, listed.stderr[-3000:]
    assert "my-first-fit" in listed.stdout

    # --import-mode=importlib: the test imports the installed module, not the file beside it
    tested = run_in(
        python, "-m", "pytest", "-q", "-p", "no:cacheprovider", "--import-mode=importlib",
        str(source / "test_my_solver.py"), cwd=elsewhere,
    )  # fmt: skip
    assert tested.returncode == 0, tested.stdout[-3000:] + tested.stderr[-3000:]
    assert re.search(r"\b(\d+) passed\b", tested.stdout), tested.stdout
    assert int(re.search(r"\b(\d+) passed\b", tested.stdout).group(1)) >= 5
