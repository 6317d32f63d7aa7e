"""The ``harness`` command line.

Built-in commands: ``rigs`` (generate, info, warp, convert, fetch), ``list``, ``run``; ``pack`` is the
`session` package's, ``report``, ``compare`` and ``show`` the `reports` package's (entry points).
Other distributions add commands through the entry-point group ``harness.commands``: each entry point names a
`click.Command` (or a ``typer.Typer`` app) and is imported only when its command runs or shows its own help.
A built-in command's module is imported the same way: ``harness --help`` lists the built-ins from their
summaries here (`BUILTIN`), so that it starts at once, and a plugin command by importing it.

User errors (`registry.HarnessError`: unknown names, malformed files, an occupied output directory; and a
missing file or folder, no permission, a full disk) end as one line on stderr saying what to do, with exit
code 2.
Ctrl-C and SIGTERM stop a command alike (the clean-up of either runs) with exit code 128 + the signal's
number (130, 143). Any other exception, a plugin's own ``KeyboardInterrupt`` included, is a fault of the
program: a short traceback and where to report it, with exit code 70 (``EX_SOFTWARE``).
"""

from __future__ import annotations

import errno
import importlib.metadata
import os
import signal
import sys
import traceback
import warnings
from dataclasses import dataclass
from typing import IO, NoReturn

import click

from harness._cli_types import terminal
from registry import HarnessError, handle_stop_signals, raised_without_signal, stop_signal

#: Entry-point group through which other packages add ``harness`` subcommands.
COMMANDS_GROUP = "harness.commands"


@dataclass(frozen=True)
class Builtin:
    """A built-in command: where it is defined, and the first sentence of its help (the summary that
    ``harness --help`` shows; a test keeps it equal to the command's own)."""

    module: str
    attribute: str
    summary: str

    def short_help(self, limit: int) -> str:
        """The summary shortened to ``limit`` characters as click shortens a command's help."""
        return click.Command(self.attribute, help=self.summary).get_short_help_str(limit)


BUILTIN = {
    "rigs": Builtin(
        "harness._cli_rigs", "rigs", "Generate, inspect, warp, convert and fetch blendshape rigs."
    ),
    "list": Builtin(
        "harness._cli_list",
        "list_command",
        "Solvers and transfers (what each is, availability with the reason, capabilities, versions), rig "
        "presets, warps.",
    ),
    "run": Builtin(
        "harness._cli_run",
        "run",
        "Run the grid rigs x warps x solvers x packing parameters x repetitions; record every cell.",
    ),
}


class UserError(click.ClickException):
    """A one-line error for the user (exit code 2)."""

    exit_code = 2

    def show(self, file: IO[str] | None = None) -> None:
        from rich.markup import escape

        terminal(stderr=True).print(f"[bold red]error:[/] {escape(self.format_message())}")


def _plugin_entry_points() -> dict[str, importlib.metadata.EntryPoint]:
    """The ``harness.commands`` plugins by name, read afresh (a name registered twice warns)."""
    from registry import collect

    return collect(importlib.metadata.entry_points(group=COMMANDS_GROUP), "command")


def _as_click_command(name: str, value: object) -> click.Command:
    """The click command a plugin's entry point names: a click command, or a typer app (the plugin that
    made one has typer installed; the harness itself does not need it)."""
    if isinstance(value, click.Command):
        return value
    typer = sys.modules.get("typer")
    if typer is not None and isinstance(value, typer.Typer):
        return typer.main.get_command(value)
    raise TypeError(f"it is a {type(value).__name__}, not a click command or a typer app")


def _broken_command(name: str, message: str) -> click.Command:
    """Stand-in for a plugin command that failed to load: listed as such, and says why when run."""

    def fail(**_: object) -> None:
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
        return sorted({*BUILTIN, *_plugin_entry_points()})

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name in BUILTIN:
            builtin = BUILTIN[cmd_name]
            return getattr(importlib.import_module(builtin.module), builtin.attribute)
        entry = _plugin_entry_points().get(cmd_name)
        if entry is None:
            return None
        try:
            return _as_click_command(cmd_name, entry.load())
        except Exception as error:  # noqa: BLE001 - a broken plugin must not break the other commands
            return _broken_command(
                cmd_name, f"the {cmd_name!r} command ({entry.value}) failed to load: {error}"
            )

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        """The command list of ``harness --help``: built-ins by their summaries (not imported), plugins by
        their own short help (imported)."""
        names = self.list_commands(ctx)
        limit = formatter.width - 6 - max(map(len, names), default=0)
        rows = []
        for name in names:
            if name in BUILTIN:
                rows.append((name, BUILTIN[name].short_help(limit)))
                continue
            command = self.get_command(ctx, name)
            if command is not None and not command.hidden:
                rows.append((name, command.get_short_help_str(limit)))
        if rows:
            with formatter.section("Commands"):
                formatter.write_dl(rows)

    def invoke(self, ctx: click.Context) -> object:
        try:
            return super().invoke(ctx)
        except (click.ClickException, click.exceptions.Exit, click.Abort):
            raise
        except HarnessError as error:
            raise UserError(_one_line(error)) from None
        except OSError as error:
            if _is_records_write_error(error):
                raise UserError(
                    f"{error.strerror}; free space, then finish with: harness run --resume OUT"
                ) from None
            if isinstance(error, _USER_OS_ERRORS) or error.errno in _FULL_OR_READ_ONLY:
                raise UserError(_one_line(error)) from None
            _report_fault(error)
        except KeyboardInterrupt as interrupt:
            if raised_without_signal():
                _report_fault(interrupt)
            stopped = stop_signal()
            word = "terminated" if stopped is not None and stopped != signal.SIGINT else "interrupted"
            terminal(stderr=True).print(f"[yellow]{word}[/]")
            sys.exit(128 + (stopped or signal.SIGINT))
        except Exception as error:  # noqa: BLE001 - the boundary that reports the program's own faults
            _report_fault(error)


#: File errors a user can fix (a wrong path, a folder given for a file, no permission): one line each.
_USER_OS_ERRORS = (FileNotFoundError, IsADirectoryError, NotADirectoryError, PermissionError)
#: ... and a full disk, an exceeded quota or a read-only file system.
_FULL_OR_READ_ONLY = {errno.ENOSPC, errno.EDQUOT, errno.EROFS}
#: Frames of the traceback shown for a fault of the program (the innermost ones).
FAULT_FRAMES = 6
#: Where faults of the program are reported.
REPORT_TO = "the issue tracker of expression-packing-harness"


def _report_fault(error: BaseException) -> NoReturn:
    """End the command on an exception that is no user error: the innermost frames of its traceback,
    and a request to report it (exit code 70, ``EX_SOFTWARE``)."""
    from rich.markup import escape

    shown = "".join(traceback.format_exception(error, limit=-FAULT_FRAMES, chain=False)).rstrip()
    console = terminal(stderr=True)
    console.print(escape(shown), highlight=False, soft_wrap=True)
    console.print(
        f"[bold red]error:[/] unexpected {type(error).__name__} (a fault of harness, not of the input); "
        f"please report it to {REPORT_TO} with the command and this output"
    )
    sys.exit(os.EX_SOFTWARE)


def _is_records_write_error(error: BaseException) -> bool:
    """Whether the records store failed to write (checked without importing the store: a command that
    never imported it cannot have raised its error)."""
    records = sys.modules.get("harness._records")
    return records is not None and isinstance(error, records.RecordsWriteError)


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


#: How Python shows a warning (file, line, category, message and the source line).
_PYTHON_SHOW_WARNING = warnings.showwarning


def _show_warning(
    message: Warning | str,
    category: type[Warning],
    filename: str,
    lineno: int,
    file: IO[str] | None = None,
    line: str | None = None,
) -> None:
    """A rig reader's warning (`rigs.RigWarning`: it names the file and what was left out) as one plain
    ``warning:`` line on stderr; any other warning as Python shows it."""
    readers = sys.modules.get("rigs._rig")  # (a RigWarning was raised only if the rig package is loaded)
    if readers is not None and issubclass(category, readers.RigWarning):
        from rich.markup import escape

        terminal(stderr=True).print(f"[yellow]warning:[/] {escape(str(message))}")
        return
    _PYTHON_SHOW_WARNING(message, category, filename, lineno, file, line)


def main(argv: list[str] | None = None) -> None:
    """Console-script entry point (``harness = harness.cli:main``); ``argv`` defaults to the process's.
    Warnings of the rig readers print as one plain line each (`_show_warning`).

    The command ends the process (``SystemExit``). SIGINT and SIGTERM stop the command alike
    (`registry.handle_stop_signals`).
    """
    warnings.showwarning = _show_warning
    with handle_stop_signals():
        cli.main(args=argv, prog_name="harness")
