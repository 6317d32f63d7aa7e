"""The harness's view of the plugin registries (`solvers`, `transfer`) and of the rig catalogue (`rigs`).

Every look-up by name goes through here, so that an unknown name fails in one way: a `ValueError` that
lists the valid names.
"""

from __future__ import annotations

import importlib.metadata
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from harness._grid import NO_WARP
from harness._rigspec import is_rig_file

ALL = "all"


@dataclass(frozen=True)
class PluginInfo:
    """What `harness list` shows about one solver or transfer plugin.

    Attributes
    ----------
    description : str
        One line: what the plugin is (`describe`), then whether a solver may overlap shapes or whether a
        transfer uses the training examples; empty for a plugin that does not load.
    """

    kind: str
    name: str
    available: bool
    reason: str
    version: str
    capabilities: dict[str, Any]
    description: str = ""

    def as_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "available": self.available,
            "reason": self.reason,
            "version": self.version,
            "description": self.description,
            "capabilities": self.capabilities,
        }


def solver_names() -> list[str]:
    """Every registered solver plugin, available or not."""
    import solvers

    return list(solvers.names())


def transfer_names() -> list[str]:
    """Every registered transfer plugin."""
    import transfer

    return list(transfer.names())


def solver(name: str) -> Any:
    """The named solver plugin behind the framework's checks and normalisation (`solvers.get`)."""
    import solvers

    return solvers.get(name)


def solver_info(name: str) -> PluginInfo:
    """Availability (with the reason), backend version and capabilities of a solver, without solving."""
    import solvers

    try:
        found = solvers.info([name])[0]
    except Exception as error:  # noqa: BLE001 - a plugin that fails to load is listed as unavailable
        return PluginInfo("solver", name, False, f"{type(error).__name__}: {error}", "", {})
    capabilities = _as_dict(found.capabilities)
    description = ""
    if found.capabilities is not None:  # (else the plugin did not load: the reason says why)
        plugin = importlib.metadata.EntryPoint(name, found.entry_point, "").load()  # (imported by info)
        description = f"{describe(plugin)} {_overlap_clause(found.capabilities.max_overlap)}".lstrip()
    return PluginInfo("solver", name, found.available, found.reason, found.version, capabilities, description)


def transfer_info(name: str) -> PluginInfo:
    """Whether a transfer plugin loads, and its declared traits (``binary_weights``, ``uses_examples``)."""
    import transfer

    try:
        method = transfer.get(name)
    except Exception as error:  # noqa: BLE001 - listed as unavailable with the reason
        return PluginInfo("transfer", name, False, f"{type(error).__name__}: {error}", "", {})
    traits = {
        trait: bool(getattr(method, trait))
        for trait in ("uses_examples", "binary_weights")
        if hasattr(method, trait)
    }
    clause = _examples_clause(traits["uses_examples"]) if "uses_examples" in traits else ""
    description = f"{describe(method)} {clause}".strip()
    return PluginInfo("transfer", name, True, "", "", traits, description)


def describe(plugin: Any) -> str:
    """What a plugin is, in one line: its class's ``description`` attribute, else the first line of its
    class's own docstring (not one inherited from a base class), else an empty string."""
    cls = plugin if isinstance(plugin, type) else type(plugin)
    text = getattr(cls, "description", None)
    if not isinstance(text, str) or not text.strip():
        text = cls.__dict__.get("__doc__") or ""
    lines = text.strip().splitlines()
    return " ".join(lines[0].split()) if lines else ""


def _overlap_clause(max_overlap: float) -> str:
    if max_overlap == 0:
        return "Shapes in one expression never overlap."
    return f"Shapes in one expression may overlap: up to {max_overlap:.0%} of a shape's active vertices."


def _examples_clause(uses_examples: bool) -> str:
    return "Uses the training examples." if uses_examples else "Ignores the training examples."


def _as_dict(value: Any) -> dict[str, Any]:
    if value is None:
        return {}
    if hasattr(value, "as_dict"):
        return dict(value.as_dict())
    if isinstance(value, dict):
        return dict(value)
    from dataclasses import asdict, is_dataclass

    return asdict(value) if is_dataclass(value) else {}


def expand_names(requested: Iterable[str], known: list[str], what: str, option: str) -> tuple[str, ...]:
    """Requested plugin names with ``all`` expanded to every known one, in order, without repeats.

    Raises
    ------
    ValueError
        Naming the unknown names and listing the valid ones.
    """
    names: list[str] = []
    for name in requested:
        for expanded in known if name == ALL else [name]:
            if expanded not in names:
                names.append(expanded)
    unknown = [name for name in names if name not in known]
    if unknown:
        raise ValueError(
            f"unknown {what} {', '.join(map(repr, unknown))} for {option}; valid: {', '.join(known)} or {ALL}"
        )
    if not names:
        raise ValueError(f"{option} names no {what}; valid: {', '.join(known)} or {ALL}")
    return tuple(names)


def check_rigs(names: Iterable[str]) -> None:
    """Every rig argument names an existing file or folder or a generator preset."""
    import rigs

    bad = [name for name in names if not is_rig_file(name) and name not in rigs.PRESETS]
    if bad:
        raise ValueError(
            f"unknown rig {', '.join(map(repr, bad))} for --rigs: not a file or folder, and not a preset "
            f"(presets: {', '.join(sorted(rigs.PRESETS))})"
        )


def check_warps(names: Iterable[str]) -> None:
    """Every warp name is a `rigs.WARPS` preset or ``none``."""
    import rigs

    bad = [name for name in names if name != NO_WARP and name not in rigs.WARPS]
    if bad:
        raise ValueError(
            f"unknown warp {', '.join(map(repr, bad))} for --warps; valid: {', '.join(sorted(rigs.WARPS))} "
            f"or {NO_WARP}"
        )
