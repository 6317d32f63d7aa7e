"""``run.json``: its one schema (`harness._run` describes its keys), checked on every read (`read_run`), and
the cells of the grid it describes (`run_cells`), which every reader of records keeps to.

Every command that reads a run (``--resume``, ``show``, ``report``, ``compare``, ``instances export``) reads
``run.json`` through `harness.read_run`, which checks it here: a value of the wrong type (``config.mu``
``["abc"]``, ``config.rigs`` 5, ``time_limit`` ``"fast"``, ``git`` 5), a missing ``state`` or ``config``, or a
``state`` the harness never writes is one line naming the file, the key and what it holds, never an
exception from deep inside a reader. The types of ``config`` are those of `harness._grid.RunConfig`'s fields
(tuples as JSON lists, ``regions`` an object of name -> vertex indices), so a field added there is checked
with no list to update here. A run of format 2 or later holds every field `RunConfig` cannot do without,
each within its bound (`harness._bounds`); earlier ones may hold fewer.

A part file belongs to a run only when its cell is one of the run's grid: `run_cells` gives their ids, from
``config`` and ``rig_digests``, as ``--resume`` builds the grid, so that a part file copied in from another
run (another ``--mu``, another rig) is set aside by ``--resume`` and refused by every reader alike
(`harness._records.read_records`).
"""

from __future__ import annotations

import functools
import json
import math
import types
import typing
from collections.abc import Callable, Mapping
from dataclasses import MISSING, fields
from pathlib import Path
from typing import Any

from harness._bounds import check_bounds
from harness._grid import RunConfig
from registry import HarnessError

#: The file of a run folder that describes the run.
RUN_FILE = "run.json"
#: The states a run can be in (`harness._run`).
STATES = ("running", "complete", "incomplete", "interrupted", "failed")
#: The first format whose ``config`` holds every field without a default.
_FULL_CONFIG_FORMAT = 2


class RunDirectoryError(HarnessError):
    """The output directory cannot take this run (holds another run, is in use, or has nothing to resume),
    or its ``run.json`` is not one the harness writes."""


def read_run(out: str | Path) -> dict[str, Any]:
    """The ``run.json`` of a run directory, checked against its schema (module notes).

    Raises
    ------
    FileNotFoundError
        When ``out`` holds no run.
    RunDirectoryError
        When ``run.json`` is not readable JSON, or not of the schema: one line naming the key at fault.
    """
    path = Path(out) / RUN_FILE
    if not path.is_file():
        raise FileNotFoundError(f"{out}: no {RUN_FILE} here, so no harness run to read")
    try:
        info = json.loads(path.read_text(encoding="utf-8"))
    except RecursionError:
        raise RunDirectoryError(f"{path}: not a readable run file (nested too deeply)") from None
    except (OSError, UnicodeDecodeError, ValueError) as error:
        raise RunDirectoryError(f"{path}: not a readable run file ({error})") from None
    return check_run(path, info)


def run_cells(info: Mapping[str, Any]) -> set[str] | None:
    """The ids of the cells of a run's grid (`RunConfig.cells` with the run's ``rig_digests``), or None
    for a run whose ``run.json`` does not describe its grid (a format before 2, no ``rig_digests``).

    Raises
    ------
    RunDirectoryError
        When its ``config`` makes no grid (a value `RunConfig` refuses).
    """
    if info.get("format", 0) < _FULL_CONFIG_FORMAT or "rig_digests" not in info:
        return None
    try:
        config = RunConfig.from_dict(info["config"])
        return {spec.id for spec in config.cells(info["rig_digests"])}
    except (HarnessError, TypeError, ValueError) as error:
        raise RunDirectoryError(f"{RUN_FILE}: its config makes no grid ({error})") from None


def _text(value: object) -> bool:
    return isinstance(value, str)


def _whole(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _optional(check: Callable[[object], bool]) -> Callable[[object], bool]:
    return lambda value: value is None or check(value)


def _list_of(check: Callable[[object], bool]) -> Callable[[object], bool]:
    return lambda value: isinstance(value, list) and all(check(item) for item in value)


def _object_of(check: Callable[[object], bool]) -> Callable[[object], bool]:
    return lambda value: (
        isinstance(value, dict) and all(isinstance(key, str) and check(item) for key, item in value.items())
    )


def _anything(value: object) -> bool:
    return True


def _git(value: object) -> bool:
    return (
        isinstance(value, dict)
        and _optional(_text)(value.get("commit"))
        and _optional(lambda dirty: isinstance(dirty, bool))(value.get("dirty"))
    )


def _versions(value: object) -> bool:
    if not isinstance(value, dict):
        return False
    plugins = [value.get(kind) for kind in ("solvers", "transfers")]
    return all(kind is None or _object_of(_optional(_object_of(_anything)))(kind) for kind in plugins)


#: The keys of ``run.json`` but ``config``: (what a value must be, in words; its check; required).
_KEYS: dict[str, tuple[str, Callable[[object], bool], bool]] = {
    "format": ("an integer", _whole, True),
    "state": (f"one of {', '.join(STATES)}", lambda value: value in STATES, True),
    "command": ("a list of strings", _list_of(_text), False),
    "n_cells": ("an integer", _whole, False),
    "rig_digests": ("an object of strings", _object_of(_text), False),
    "rig_inputs": ("an object of objects", _object_of(_object_of(_anything)), False),
    "versions": ("an object (solvers and transfers objects of objects)", _versions, False),
    "git": ("an object with a string 'commit' and a true/false 'dirty'", _git, False),
    "machine": ("an object", _object_of(_anything), False),
    "execution": ("an object", _object_of(_anything), False),
    "started": ("a time or null", _optional(_text), False),
    "finished": ("a time or null", _optional(_text), False),
    "resumed": ("a list of times", _list_of(_text), False),
    "error": ("a string", _text, False),
    "lost": ("an object of objects", _object_of(_object_of(_anything)), False),
    "crashes": ("an object of objects", _object_of(_object_of(_anything)), False),
}


def check_run(path: Path, document: object) -> dict[str, Any]:
    """``document`` (read from ``path``) when it is a ``run.json`` of this schema (module notes).

    Raises
    ------
    RunDirectoryError
        One line naming ``path``, the key and what it holds instead.
    """
    if not isinstance(document, dict):
        raise RunDirectoryError(f"{path}: not a run file (expected an object, got {_kind(document)})")
    if not isinstance(document.get("config"), dict):
        raise RunDirectoryError(f"{path}: not a run file (expected an object with a 'config' object)")
    for key, (expected, check, required) in _KEYS.items():
        if key not in document:
            if required:
                raise RunDirectoryError(f"{path}: not a run file (it has no {key!r}: expected {expected})")
            continue
        if not check(document[key]):
            raise RunDirectoryError(f"{path}: {key} must be {expected}, got {_shown(document[key])}")
    _check_config(path, document["config"], document["format"])
    return document


def _check_config(path: Path, config: Mapping[str, object], format_: int) -> None:
    """Each key of ``config`` a field of `RunConfig` holding a value of its type."""
    checks = _config_checks()
    for key, value in config.items():
        if key not in checks:
            raise RunDirectoryError(f"{path}: config has the unknown key {key!r}")
        expected, check = checks[key]
        if not check(value):
            raise RunDirectoryError(f"{path}: config.{key} must be {expected}, got {_shown(value)}")
    if format_ >= _FULL_CONFIG_FORMAT:
        missing = [name for name in _required_config() if name not in config]
        if missing:
            raise RunDirectoryError(f"{path}: config lacks {', '.join(missing)}")
        try:
            check_bounds(RunConfig.from_dict(config))
        except HarnessError as error:
            raise RunDirectoryError(f"{path}: config: {error}") from None


@functools.cache
def _config_checks() -> dict[str, tuple[str, Callable[[object], bool]]]:
    """Per `RunConfig` field: its type in words and the check of a JSON value of that type."""
    hints = typing.get_type_hints(RunConfig)
    checks = {name: _json_check(hint) for name, hint in hints.items()}
    checks["regions"] = ("an object of lists of integers", _object_of(_list_of(_whole)))
    return checks


@functools.cache
def _required_config() -> tuple[str, ...]:
    return tuple(
        field.name
        for field in fields(RunConfig)
        if field.default is MISSING and field.default_factory is MISSING
    )


def _json_check(hint: object) -> tuple[str, Callable[[object], bool]]:
    """A type annotation's JSON form in words, and its check (tuples are JSON lists)."""
    origin, arguments = typing.get_origin(hint), typing.get_args(hint)
    if origin in (types.UnionType, typing.Union):
        parts = [_json_check(argument) for argument in arguments if argument is not type(None)]
        words = " or ".join(part[0] for part in parts)
        nullable = type(None) in arguments
        return (
            f"{words} or null" if nullable else words
        ), lambda value: (nullable and value is None) or any(check(value) for _, check in parts)
    if origin is tuple and len(arguments) == 2 and arguments[1] is Ellipsis:
        words, check = _json_check(arguments[0])
        return f"a list, each {words}", _list_of(check)
    if origin is tuple:
        parts = [_json_check(argument) for argument in arguments]
        return (
            f"a list of {len(parts)} items",
            lambda value: (
                isinstance(value, list)
                and len(value) == len(parts)
                and all(check(item) for (_, check), item in zip(parts, value, strict=True))
            ),
        )
    simple: dict[object, tuple[str, Callable[[object], bool]]] = {
        bool: ("true or false", lambda value: isinstance(value, bool)),
        int: ("an integer", _whole),
        float: ("a finite number", _finite),
        str: ("a string", _text),
    }
    if hint in simple:
        return simple[hint]
    return "a value", _anything


def _finite(value: object) -> bool:
    return (_whole(value) or isinstance(value, float)) and math.isfinite(float(value))  # type: ignore[arg-type]


def _kind(value: object) -> str:
    return {list: "a list", str: "a string", bool: "true or false", type(None): "null"}.get(
        type(value), "a number" if isinstance(value, int | float) else type(value).__name__
    )


def _shown(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."
