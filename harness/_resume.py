"""What ``--resume`` compares before it runs a cell: a run's cells must all come from one set of options, one
content of every rig and one version of every solver, transfer and key library, or they are not one run.

Each function returns what changed, one entry per difference, each naming the option, the rig file or the
version and both values; `harness._run.run_grid` refuses to resume with all of them in its message.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from rigs import is_rig_path

if TYPE_CHECKING:
    from harness._grid import RunConfig
    from rigs import RigInputs


def _show(value: object) -> str:
    if isinstance(value, dict):
        return f"{len(value)} regions ({', '.join(sorted(value))})" if value else "none"
    if isinstance(value, list):
        if value and isinstance(value[0], list):
            return " ".join(",".join(map(str, item)) for item in value)
        return ",".join(_show(item) for item in value) or "none"
    if isinstance(value, bool):
        return "on" if value else "off"
    return "none" if value is None or value == "" else str(value)


def options_changed(stored: RunConfig, given: RunConfig) -> list[str]:
    """``--jmax 5 (the run has 10)``: each option given otherwise than ``run.json`` has it."""
    old, new = stored.to_dict(), given.to_dict()
    return [
        f"--{key.replace('_', '-')} {_show(new[key])} (the run has {_show(old[key])})"
        for key in old
        if old[key] != new[key]
    ]


def rigs_changed(
    previous: dict[str, Any], digests: dict[str, str], inputs: dict[str, RigInputs]
) -> list[str]:
    """``rig face/neutral.obj changed since the run started (jawOpen.obj changed, smile.obj is new)``: each
    rig whose content is not the one the run started with, naming the files that changed where
    ``run.json`` lists them (``rig_inputs``, what each rig's read opened) and the digests otherwise.

    Parameters
    ----------
    previous : dict
        The run's ``run.json``.
    digests : dict
        The rigs' digests now, by `harness._grid.digest_key`.
    inputs : dict
        What reading each rig file opened now, by rig argument (`rigs.load_with_inputs`).
    """
    from rigs import RigInputs

    stored = previous.get("rig_digests") or {}
    stored_inputs = previous.get("rig_inputs") or {}
    found = []
    for key, digest in digests.items():
        if key not in stored or stored[key] == digest:
            continue
        rig, _, seed = key.rpartition("@")
        named = rig if is_rig_path(rig) else f"{rig} (seed {seed})"
        changes: list[str] = []
        if rig in stored_inputs and rig in inputs:
            before = RigInputs.from_document(inputs[rig].root, stored_inputs[rig])
            changes = before.changes(inputs[rig])
        detail = ", ".join(changes) or f"content {digest[:19]}..., the run has {stored[key][:19]}..."
        found.append(f"rig {named} changed since the run started ({detail})")
    return list(dict.fromkeys(found))  # (a rig file is one entry per seed, all alike)


def versions_changed(previous: dict[str, Any], current: dict[str, Any]) -> list[str]:
    """``highspy 1.12.0 (the run has 1.11.0)``, ``solver cpsat 9.15.6068 (the run has 9.14.0)``: each
    library, solver or transfer whose version is not the one in ``run.json``'s ``versions``.

    Only what both know is compared: a library the run did not record (an older ``run.json``) or a
    plugin the run does not use is no difference.
    """
    stored = previous.get("versions") or {}
    found = []
    for name, version in current.items():
        if name in ("solvers", "transfers") or name not in stored:
            continue
        if stored[name] != version:
            found.append(f"{name} {version or 'not installed'} (the run has {stored[name] or 'none'})")
    for kind in ("solvers", "transfers"):
        before, now = stored.get(kind) or {}, current.get(kind) or {}
        for name in sorted(set(before) & set(now)):
            old, new = (before[name] or {}).get("version"), (now[name] or {}).get("version")
            if old != new:
                found.append(f"{kind[:-1]} {name} {new or 'unavailable'} (the run has {old or 'none'})")
    return found
