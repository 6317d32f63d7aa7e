"""``harness --help`` lists a plugin command from its source when that says its help plainly, and imports it
otherwise; either way the summary is the command's own."""

from __future__ import annotations

import importlib
import importlib.metadata
import sys
import textwrap

import click
import pytest
from click.testing import CliRunner

from harness._cli_summary import static_command
from harness.cli import COMMANDS_GROUP, cli

HEADER = "import click\nfrom click import command as cmd, group\nimport typer\n\n"

#: Module sources whose ``run`` command is read from the source, without importing the module.
READABLE = {
    "docstring": '@click.command()\n@click.argument("x")\ndef run(x):\n    """Run it.\n\n    More."""\n',
    "literal_help": (
        '@click.command("run", help="Adjacent " "literals: one string. Second sentence.")\n'
        'def run():\n    """No."""\n'
    ),
    "short_help": '@cmd(short_help="  Short and sweet. ", help="Long.")\ndef run():\n    pass\n',
    "hidden": "@click.command(hidden=True)\ndef run():\n    pass\n",
    "deprecated": '@click.command(deprecated="use walk")\ndef run():\n    """Old."""\n',
    "group": '@group()\ndef run():\n    """Several things."""\n',
    "bare": "@click.command\ndef run():\n    '''Bare decorator.'''\n",
}
#: Module sources whose ``run`` command only an import tells.
IMPORTED = {
    "fstring": 'WHERE = "x"\n\n@click.command(help=f"To {WHERE}.")\ndef run():\n    pass\n',
    "computed": '@click.command(help="a" + "b")\ndef run():\n    pass\n',
    "custom_class": "@click.command(cls=click.Group)\ndef run():\n    '''No.'''\n",
    "outer_decorator": "def wrap(f):\n    return f\n\n@wrap\n@click.command()\ndef run():\n    '''No.'''\n",
    "rebound": "@click.command()\ndef run():\n    '''No.'''\n\nrun = click.Group('run')\n",
    "star_import": "from os.path import *\n\n@click.command()\ndef run():\n    '''No.'''\n",
    "typer_app": "run = typer.Typer(help='An app.')\n\n@run.command()\ndef go():\n    pass\n",
    "other_command": "def command():\n    return click.command()\n\n@command()\ndef run():\n    '''No.'''\n",
}
SOURCES = READABLE | IMPORTED


@pytest.fixture
def modules(tmp_path, monkeypatch):
    """One importable module per entry of `SOURCES`, none imported yet."""
    for name, body in SOURCES.items():
        (tmp_path / f"summary_{name}.py").write_text(HEADER + textwrap.dedent(body))
    (tmp_path / "summary_broken.py").write_text("def run(:\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    importlib.invalidate_caches()
    yield
    for name in [*SOURCES, "broken"]:
        sys.modules.pop(f"summary_{name}", None)


def _entry(name: str) -> importlib.metadata.EntryPoint:
    return importlib.metadata.EntryPoint(name, f"summary_{name}:run", COMMANDS_GROUP)


@pytest.mark.parametrize("name", sorted(SOURCES))
def test_a_plain_source_gives_the_commands_own_summary_without_importing_it(modules, name) -> None:
    found = static_command(_entry(name))
    assert f"summary_{name}" not in sys.modules
    assert (found is not None) == (name in READABLE)
    if found is None:
        return
    real = importlib.import_module(f"summary_{name}").run
    assert found.hidden == real.hidden and type(found) is type(real)
    for limit in (10, 30, 45, 80, 200):
        assert found.get_short_help_str(limit) == real.get_short_help_str(limit)


def test_unreadable_or_imported_modules_are_left_to_the_import(modules) -> None:
    assert static_command(_entry("broken")) is None
    assert static_command(importlib.metadata.EntryPoint("x", "summary_missing:run", COMMANDS_GROUP)) is None
    importlib.import_module("summary_docstring")
    assert static_command(_entry("docstring")) is None  # imported already: the command itself is at hand


def test_installed_plugin_commands_are_listed_with_their_own_summary() -> None:
    entries = importlib.metadata.entry_points(group=COMMANDS_GROUP)
    assert {"report", "compare"} <= set(entries.names)
    for entry in entries:
        found = static_command(entry) if entry.module not in sys.modules else None
        if found is None:
            continue
        real = entry.load()
        for limit in (20, 45, 80, 104):
            assert found.get_short_help_str(limit) == real.get_short_help_str(limit), entry


def test_help_lists_a_plain_plugin_without_importing_it(test_plugins) -> None:
    listing = CliRunner().invoke(cli, ["--help"], terminal_width=200).output
    assert "Say hello (a click command added through harness.commands)." in listing
    assert "Greetings (a typer app" in listing  # (a typer app is imported to be listed)
    assert "(unavailable: failed to load)" in listing
    command = cli.get_command(click.Context(cli), "hello")
    assert command.get_short_help_str(200) == "Say hello (a click command added through harness.commands)."
