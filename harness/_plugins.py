"""The harness's view of the plugin registries (`solvers`, `transfer`) and of the rig catalogue (`rigs`).

Every look-up by name goes through here, so that an unknown name fails in one way: a `ValueError` that
lists the valid names.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from harness._grid import NO_WARP
from harness._settings import split_label
from registry import HarnessError, checked_settings, declared_settings

if TYPE_CHECKING:
    from registry import PluginInfo
    from solvers import Capabilities, LoadedSolver

ALL = "all"


def solver_names() -> list[str]:
    """Every registered solver plugin, available or not."""
    import solvers

    return list(solvers.names())


def transfer_names() -> list[str]:
    """Every registered transfer plugin."""
    import transfer

    return list(transfer.names())


def load_solver(label: str) -> LoadedSolver:
    """The solver plugin of a label (``cpsat`` or ``cpsat[workers=2]``), made with the label's settings and
    behind the framework's checks and normalisation (`solvers.get`).

    Raises
    ------
    HarnessError
        For settings the plugin refuses, naming the label and what the plugin said.
    """
    import solvers

    name, settings = split_label(label)
    if not settings:
        return solvers.get(name)
    try:
        return solvers.get(name, **dict(settings))
    except (TypeError, ValueError) as error:
        raise HarnessError(f"--solver {label}: {error}") from None


def solver_capabilities(label: str) -> Capabilities:
    """What a label's solver declares, made with the label's settings (a setting may change it: the
    overlap of ``greedy-overlap[overlap=0.2]``), without checking its availability."""
    import solvers

    name, settings = split_label(label)
    return solvers.solver_class(name)(**dict(settings)).capabilities


def solver_info(label: str) -> PluginInfo:
    """Availability (with the reason), backend version and class of a label's solver, without solving."""
    import solvers

    return solvers.info([split_label(label)[0]])[0]


def transfer_method(label: str) -> object:
    """The transfer method of a label (``ebfr`` or ``ebfr[beta=gcv]``), made with the label's settings."""
    import transfer

    name, settings = split_label(label)
    return transfer.get(name, **dict(settings))


def transfer_info(label: str) -> PluginInfo:
    """Availability (with the reason), version and class of a label's transfer method."""
    import transfer

    return transfer.info([split_label(label)[0]])[0]


def listing(info: PluginInfo) -> dict[str, Any]:
    """The JSON-ready row of ``harness list``: the plugin's `PluginInfo`, its one-line description, what it
    declares (a solver's capabilities; whether a transfer method uses the training examples and takes 0/1
    weights only) and its settings (`settings_listing`)."""
    plugin = info.plugin
    if plugin is None:  # (it did not load: the reason says why)
        return {**info.as_dict(), "description": "", "capabilities": {}, "settings": []}
    if hasattr(plugin, "capabilities"):
        declared = dict(plugin.capabilities.as_dict())
        clause = _overlap_clause(plugin.capabilities.max_overlap)
    else:
        declared = {trait: bool(getattr(plugin, trait)) for trait in ("uses_examples", "binary_weights")}
        clause = _examples_clause(declared["uses_examples"])
    return {
        **info.as_dict(),
        "description": f"{describe(plugin)} {clause}".strip(),
        "capabilities": declared,
        "settings": settings_listing(plugin),
    }


def describe(plugin: object) -> str:
    """What a plugin is, in one line: its class's ``description`` attribute, else the first paragraph of
    its class's own docstring (not one inherited from a base class) joined into one line, else an empty
    string."""
    cls = plugin if isinstance(plugin, type) else type(plugin)
    text = getattr(cls, "description", None)
    if not isinstance(text, str) or not text.strip():
        text = cls.__dict__.get("__doc__") or ""
    paragraph = text.strip().split("\n\n")[0]
    return " ".join(paragraph.split())


def _overlap_clause(max_overlap: float) -> str:
    if max_overlap == 0:
        return "Shapes in one expression never overlap."
    return f"Shapes in one expression may overlap: up to {max_overlap:.0%} of a shape's active vertices."


def _examples_clause(uses_examples: bool) -> str:
    return "Uses the training examples." if uses_examples else "Ignores the training examples."


def expand_names(requested: Iterable[str], known: list[str], what: str, option: str) -> tuple[str, ...]:
    """Requested plugin labels (a name, or a name with settings: `harness._settings`) with ``all`` expanded
    to every known name, in order, without repeats; a label naming a Python file (``./my_solver.py``,
    settings allowed) registers the plugin it defines and stands for its name (`_registered`).

    Raises
    ------
    ValueError
        Naming the unknown names and listing the valid ones.
    """
    given = list(requested)
    requested = [_registered(label, what) for label in given]
    registered = [_plain_name(label) for label, was in zip(requested, given, strict=True) if label != was]
    known = [*known, *(name for name in registered if name not in known)]
    names: list[str] = []
    for name in requested:
        for expanded in known if name == ALL else [name]:
            if expanded not in names:
                names.append(expanded)
    try:
        unknown = [name for name in names if split_label(name)[0] not in known]
    except HarnessError as error:
        raise HarnessError(f"{option} {error}") from None
    if unknown:
        raise HarnessError(
            f"unknown {what} {', '.join(map(repr, unknown))} for {option}; valid: {', '.join(known)} or {ALL}"
        )
    if not names:
        raise HarnessError(f"{option} names no {what}; valid: {', '.join(known)} or {ALL}")
    return tuple(names)


def _plain_name(label: str) -> str:
    return label.split("[", 1)[0]


def _registered(label: str, what: str) -> str:
    """``label`` with a plugin file's path (a name ending ``.py``) replaced by the name of the plugin it
    defines, registered for this process and its workers (`solvers.add_file`, `transfer.add_file`)."""
    path = _plain_name(label)
    if not path.endswith(".py"):
        return label
    import solvers
    import transfer

    register = solvers.add_file if what == "solver" else transfer.add_file
    return register(path) + label[len(path) :]


def register_recorded_files(versions: dict[str, Any]) -> None:
    """Register again the plugin files a run recorded (``run.json``'s ``versions``: a plugin whose entry
    point is a ``.py`` file), so that ``--resume`` finds them; a file changed since is refused by the
    version check, one that is gone by the names check."""
    import solvers
    import transfer

    for kind, register in (("solvers", solvers.add_file), ("transfers", transfer.add_file)):
        for entry in (versions.get(kind) or {}).values():
            path = entry.get("entry_point", "") if isinstance(entry, dict) else ""
            if isinstance(path, str) and path.endswith(".py") and Path(path).is_file():
                register(path)


def check_settings(
    solver_labels: Iterable[str], transfer_labels: Iterable[str], *, solver_option: str = "--solvers"
) -> None:
    """Every label's settings make its plugin (a solver's class or a transfer method), before any cell runs.

    A solver that declares its settings (`registry.Setting`) has every value checked against the
    declaration (type, range, choices) first; one that declares none is made with them.

    Raises
    ------
    ValueError
        Naming the option (``solver_option`` for a solver), the label and what is wrong.
    """
    for label in solver_labels:
        try:
            name, settings = split_label(label)
        except HarnessError as error:
            raise HarnessError(f"{solver_option} {error}") from None
        if not settings:
            continue
        import solvers

        try:
            cls = solvers.solver_class(name)
            cls(**checked_settings(cls, dict(settings)))
        except (TypeError, ValueError) as error:
            raise HarnessError(f"{solver_option} {label}: {_first_line(error)}") from None
    for label in transfer_labels:
        if split_label(label)[1]:
            try:
                transfer_method(label)
            except (TypeError, ValueError) as error:
                raise HarnessError(f"--transfers {label}: {error}") from None


def _first_line(error: BaseException) -> str:
    lines = str(error).strip().splitlines()
    return lines[0] if lines else type(error).__name__


def settings_listing(plugin: object) -> list[dict[str, Any]]:
    """The settings a plugin declares (`registry.Setting`), JSON-ready: name, type, default, domain, help;
    a dataclass plugin (a transfer method) that declares none lists its fields with their defaults."""
    declared = declared_settings(plugin)
    if declared is not None:
        return [
            {
                "name": setting.name,
                "type": setting.type.__name__,
                "default": setting.default,
                "domain": setting.domain(),
                "help": setting.help,
            }
            for setting in declared
        ]
    import dataclasses

    if not (isinstance(plugin, type) and dataclasses.is_dataclass(plugin)):
        return []
    return [
        {
            "name": field.name,
            "type": str(field.type),
            "default": field.default
            if isinstance(field.default, bool | int | float | str)
            else repr(field.default),
            "domain": "",
            "help": "",
        }
        for field in dataclasses.fields(plugin)
        if field.default is not dataclasses.MISSING
    ]


def check_rigs(names: Iterable[str]) -> None:
    """Every rig argument names an existing file or folder or a generator preset."""
    import rigs

    bad = [name for name in names if not rigs.is_rig_path(name) and name not in rigs.PRESETS]
    if bad:
        raise HarnessError(
            f"unknown rig {', '.join(map(repr, bad))} for --rigs: not a file or folder, and not a preset "
            f"(presets: {', '.join(sorted(rigs.PRESETS))})"
        )


def check_warps(names: Iterable[str]) -> None:
    """Every warp name is a `rigs.WARPS` preset or ``none``."""
    import rigs

    bad = [name for name in names if name != NO_WARP and name not in rigs.WARPS]
    if bad:
        raise HarnessError(
            f"unknown warp {', '.join(map(repr, bad))} for --warps; valid: {', '.join(sorted(rigs.WARPS))} "
            f"or {NO_WARP}"
        )
