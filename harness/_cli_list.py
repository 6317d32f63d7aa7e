"""``harness list``: what is installed (solver and transfer plugins, rig presets, warps, run presets).

It imports the plugins' modules (their classes say what they are and can do) but neither their backends nor
the records store, so that it answers at once.
"""

from __future__ import annotations

import json
from typing import TYPE_CHECKING, Any

import click

from harness import _plugins as plugins
from harness._cli_types import terminal

if TYPE_CHECKING:
    from rich.table import Table


def catalogue() -> dict[str, Any]:
    """Everything `harness list` reports, JSON-ready."""
    import rigs
    from harness._grid import PRESETS as RUN_PRESETS

    return {
        "solvers": [plugins.listing(plugins.solver_info(name)) for name in plugins.solver_names()],
        "transfers": [plugins.listing(plugins.transfer_info(name)) for name in plugins.transfer_names()],
        "rig_presets": sorted(rigs.PRESETS),
        "warps": sorted(rigs.WARPS),
        "run_presets": sorted(RUN_PRESETS),
    }


@click.command("list")
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of tables.")
def list_command(as_json: bool) -> None:
    """Solvers and transfers (what each is, availability with the reason, capabilities, versions), rig
    presets, warps."""
    found = catalogue()
    if as_json:
        click.echo(json.dumps(found, indent=2))
        return
    for kind in ("solvers", "transfers"):
        terminal().print(_plugin_table(kind, found[kind]))
    terminal().print(f"rig presets: {', '.join(found['rig_presets'])}")
    terminal().print(f"warps: {', '.join(found['warps'])}")
    terminal().print(f"run presets: {', '.join(found['run_presets'])}")


def _plugin_table(kind: str, items: list[dict[str, Any]]) -> Table:
    """One row per plugin: its name, whether it is available and its version, then one folded column with
    what it is, its true capabilities (or, when it cannot run, the reason) and its settings, so that the
    table reads at 80 columns."""
    from rich import box
    from rich.markup import escape
    from rich.table import Table

    table = Table(title=kind, title_justify="left", box=box.SIMPLE_HEAD, show_lines=True)
    table.add_column("name", no_wrap=True)
    table.add_column("available", no_wrap=True)
    table.add_column("version", overflow="fold", max_width=14)
    table.add_column("what it is, can do and takes", overflow="fold", ratio=1)
    for item in items:
        flags = ", ".join(name for name, value in item["capabilities"].items() if value is True) or "none"
        detail = f"can: {flags}" if item["available"] else f"[yellow]{escape(item['reason'])}[/]"
        mark = "[green]yes[/]" if item["available"] else "[red]no[/]"
        settings = "; ".join(_setting_text(setting) for setting in item["settings"])
        about = [escape(item["description"]) or "-", detail]
        about += [f"settings: {escape(settings)}"] if settings else []
        table.add_row(item["name"], mark, item["version"] or "-", "\n".join(about))
    return table


def _setting_text(setting: dict[str, Any]) -> str:
    """``workers=1: an integer in [1, 64]`` (the default, then what a value may be)."""
    default = "the backend's own" if setting["default"] is None else setting["default"]
    default = {True: "on", False: "off"}.get(default, default) if isinstance(default, bool) else default
    return f"{setting['name']}={default}" + (f": {setting['domain']}" if setting["domain"] else "")
