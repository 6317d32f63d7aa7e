"""The ``harness`` command line.

Built-in commands: ``rigs`` (generate, info, warp, convert, fetch), ``list``, ``run``, ``pack``, ``show``.
Other distributions add commands through the entry-point group ``harness.commands``: each entry point names a
`click.Command` (or a ``typer.Typer`` app) and is imported only when its command is used or listed in help.

User errors (unknown names, unreadable files, an occupied output directory) end as one line on stderr saying
what to do, with exit code 2; Ctrl-C ends with exit code 130.
"""

from __future__ import annotations

import importlib.metadata
import sys
from typing import Any

import click
from rich.markup import escape

from harness._cli_types import terminal

#: Entry-point group through which other packages add ``harness`` subcommands.
COMMANDS_GROUP = "harness.commands"

_BUILTIN = {
    "rigs": ("harness._cli_rigs", "rigs"),
    "list": ("harness._cli_show", "list_command"),
    "run": ("harness._cli_run", "run"),
    "pack": ("harness._cli_pack", "pack"),
    "show": ("harness._cli_show", "show"),
}


class UserError(click.ClickException):
    """A one-line error for the user (exit code 2)."""

    exit_code = 2

    def show(self, file: Any = None) -> None:
        terminal(stderr=True).print(f"[bold red]error:[/] {escape(self.format_message())}")


def _plugin_entry_points() -> dict[str, importlib.metadata.EntryPoint]:
    return {entry.name: entry for entry in importlib.metadata.entry_points(group=COMMANDS_GROUP)}


def _as_click_command(name: str, value: Any) -> click.Command:
    if isinstance(value, click.Command):
        return value
    import typer

    if isinstance(value, typer.Typer):
        return typer.main.get_command(value)
    raise TypeError(f"it is a {type(value).__name__}, not a click command or a typer app")


def _broken_command(name: str, message: str) -> click.Command:
    """Stand-in for a plugin command that failed to load: listed as such, and says why when run."""

    def fail(**_: Any) -> None:
        raise UserError(message)

    return click.Command(
        name,
        callback=fail,
        help=f"(unavailable) {message}",
        short_help="(unavailable: failed to load)",
        context_settings={"ignore_unknown_options": True, "allow_extra_args": True},
    )


class HarnessGroup(click.Group):
    """The top-level group: built-in commands and ``harness.commands`` plugins, all imported lazily, and
    the error boundary that turns user errors into one line."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted({*_BUILTIN, *_plugin_entry_points()})

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name in _BUILTIN:
            module, attribute = _BUILTIN[cmd_name]
            return getattr(importlib.import_module(module), attribute)
        entry = _plugin_entry_points().get(cmd_name)
        if entry is None:
            return None
        try:
            return _as_click_command(cmd_name, entry.load())
        except Exception as error:  # noqa: BLE001 - a broken plugin must not break the other commands
            return _broken_command(
                cmd_name, f"the {cmd_name!r} command ({entry.value}) failed to load: {error}"
            )

    def invoke(self, ctx: click.Context) -> Any:
        from harness._records import RecordsWriteError

        try:
            return super().invoke(ctx)
        except RecordsWriteError as error:
            raise UserError(
                f"{error.strerror}; free space, then finish with: harness run --resume OUT"
            ) from None
        except (
            ValueError,
            FileNotFoundError,
            IsADirectoryError,
            NotADirectoryError,
            PermissionError,
        ) as error:
            raise UserError(_one_line(error)) from None
        except KeyboardInterrupt:
            terminal(stderr=True).print("[yellow]interrupted[/]")
            sys.exit(130)


def _one_line(error: BaseException) -> str:
    lines = [line for line in str(error).strip().splitlines() if line.strip()]
    return lines[0] if lines else type(error).__name__


@click.group(
    cls=HarnessGroup,
    context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 110, "show_default": True},
)
@click.version_option(package_name="expression-packing-harness", prog_name="harness")
def cli() -> None:
    """Expression packing (Carrigan et al. 2020): choose the expressions to scan, solve with many
    backends, measure the transfer, record everything.

    Start with: harness run --preset quick --solvers all
    """


def main(argv: list[str] | None = None) -> None:
    """Console-script entry point (``harness = harness.cli:main``)."""
    cli.main(args=argv, prog_name="harness")
