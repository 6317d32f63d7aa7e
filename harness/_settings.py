"""Plugin settings as grid values, named as benchopt names parametrised solvers: ``cpsat[workers=1]``.

A request on the command line may give several values of a parameter and several parameters, and stands
for their Cartesian product: ``cpsat[workers=1,2]`` is ``cpsat[workers=1]`` and ``cpsat[workers=2]``;
``highs[presolve=off,on,mip_heuristic_effort=0.1]`` is two settings. Each setting is one *label*, and a
label is what the harness runs and records: ``solver`` (or ``transfer``) holds the label, so two settings of
one plugin are two cases in every table, and ``solver_settings`` holds the part in brackets. Values are
read as an integer, a float, ``on``/``true`` or ``off``/``false``, or else kept as text.
"""

from __future__ import annotations

import itertools
import re

from registry import HarnessError

#: A plugin's keyword arguments, in the order given.
Settings = tuple[tuple[str, object], ...]

_LABEL = re.compile(r"(?P<name>[^\[\]]+?)\s*(?:\[(?P<body>[^\[\]]*)\])?")
_KEY = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_WORDS = {"on": True, "true": True, "off": False, "false": False}
_INTEGER = re.compile(r"[+-]?[0-9]+")
_FLOAT = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")


def split_requests(text: str) -> list[str]:
    """Split a comma list of plugin requests at the commas outside brackets.

    Raises
    ------
    ValueError
        For an unbalanced bracket.
    """
    requests, depth, start = [], 0, 0
    for position, character in enumerate(text):
        depth += {"[": 1, "]": -1}.get(character, 0)
        if depth not in (0, 1):
            raise HarnessError(f"{text!r}: brackets must not nest or close before they open")
        if character == "," and depth == 0:
            requests.append(text[start:position])
            start = position + 1
    if depth:
        raise HarnessError(f"{text!r}: a bracket is not closed")
    requests.append(text[start:])
    return [request.strip() for request in requests if request.strip()]


def parse(request: str) -> tuple[str, list[Settings]]:
    """A request's plugin name and the settings it stands for (one empty setting without brackets).

    Raises
    ------
    ValueError
        For a malformed request, a parameter without a value or given twice, or a key that is no name.
    """
    match = _LABEL.fullmatch(request.strip())
    if match is None:
        raise HarnessError(f"{request!r}: expected NAME or NAME[key=value,...]")
    name, body = match["name"].strip(), match["body"]
    if body is None:
        return name, [()]
    values: dict[str, list[object]] = {}
    key = None
    for token in (token.strip() for token in body.split(",")):
        if "=" in token:
            key, token = (part.strip() for part in token.split("=", 1))
            if not _KEY.fullmatch(key):
                raise HarnessError(f"{request!r}: {key!r} is not a parameter name")
            if key in values:
                raise HarnessError(f"{request!r}: parameter {key!r} is given twice")
            values[key] = []
        if key is None or not token:
            raise HarnessError(f"{request!r}: expected key=value[,value...] inside the brackets")
        values[key].append(_value(token))
    if not values:
        raise HarnessError(f"{request!r}: empty brackets (leave them out for the default settings)")
    return name, [
        tuple(zip(values, combination, strict=True)) for combination in itertools.product(*values.values())
    ]


def expand(request: str) -> list[str]:
    """The labels of a request: ``cpsat[workers=1,2]`` is ``cpsat[workers=1]`` and ``cpsat[workers=2]``."""
    name, settings = parse(request)
    return [label(name, setting) for setting in settings]


def label(name: str, settings: Settings) -> str:
    """``name[key=value,...]``, values in their canonical spelling; ``name`` alone without settings."""
    return f"{name}[{settings_text(settings)}]" if settings else name


def settings_text(settings: Settings) -> str:
    """``key=value,...`` in the order given (booleans as on/off, floats in their shortest form)."""
    return ",".join(f"{key}={_spelled(value)}" for key, value in settings)


def split_label(text: str) -> tuple[str, Settings]:
    """A label's plugin name and its one setting.

    Raises
    ------
    ValueError
        When ``text`` stands for more than one setting.
    """
    name, settings = parse(text)
    if len(settings) != 1:
        raise HarnessError(f"{text!r} stands for {len(settings)} settings; give one value per parameter")
    return name, settings[0]


def _value(token: str) -> object:
    """A value as written: ASCII digits only (no ``1_0``, no other scripts' digits)."""
    if token.lower() in _WORDS:
        return _WORDS[token.lower()]
    if _INTEGER.fullmatch(token):
        return int(token)
    if _FLOAT.fullmatch(token):
        return float(token)
    return token


def _spelled(value: object) -> str:
    if isinstance(value, bool):
        return "on" if value else "off"
    return repr(value) if isinstance(value, float) else str(value)
