"""A plugin command's help read from its source, so that ``harness --help`` lists it without importing it.

An entry point of ``harness.commands`` names ``module:function``. When the module is not imported yet and
its source plainly defines that function once, decorated last (outermost) by ``click.command(...)`` or
``click.group(...)`` whose help-related arguments are literals (``help``, ``short_help``, ``hidden``,
``deprecated``; no ``cls``), the command's summary is known without running the module: it is what click
makes of those arguments, or of the function's docstring when ``help`` is not given. Anything else
(another decorator outermost, a computed help text, a typer app, an unreadable file) gives None, and the
caller imports the module as before.
"""

from __future__ import annotations

import ast
import importlib.machinery
import importlib.util
import sys
from importlib.metadata import EntryPoint
from pathlib import Path

import click

#: The click decorators that make a function a command, and the class each makes.
_DECORATORS = {"command": click.Command, "group": click.Group}
#: Arguments of those decorators that change what ``harness --help`` shows, and the literal types allowed.
_SHOWN = {"help": str, "short_help": str, "hidden": bool, "deprecated": (bool, str)}


def static_command(entry: EntryPoint) -> click.Command | None:
    """A stand-in for the command ``entry`` names that only knows its help, read from the source.

    Parameters
    ----------
    entry : EntryPoint
        A ``harness.commands`` entry point.

    Returns
    -------
    A `click.Command` (or `click.Group`) with the command's help, short help, hidden and deprecated
    settings, or None when the source does not say them plainly (see the module docstring).
    """
    module, _, attribute = entry.value.partition(":")
    module, attribute = module.strip(), attribute.strip()
    if module in sys.modules or not attribute.isidentifier():
        return None  # (an imported module costs nothing more to ask)
    path = _source(module)
    if path is None:
        return None
    try:
        tree = ast.parse(importlib.util.decode_source(path.read_bytes()), str(path))
    except (OSError, SyntaxError, UnicodeDecodeError, ValueError, RecursionError, MemoryError):
        return None
    function = _only_definition(tree, attribute)
    if function is None or not function.decorator_list:
        return None
    return _stand_in(entry.name, function, _click_names(tree))


def _source(module: str) -> Path | None:
    """The ``.py`` file of ``module``, found without importing it or its parent packages."""
    top, *rest = module.split(".")
    try:
        spec = importlib.util.find_spec(top)  # (a top-level name is found without importing anything)
        for depth in range(1, len(rest) + 1):
            if spec is None or spec.submodule_search_locations is None:
                return None
            name = ".".join([top, *rest[:depth]])
            spec = importlib.machinery.PathFinder.find_spec(name, list(spec.submodule_search_locations))
    except (ImportError, ValueError):
        return None
    if spec is None or not spec.has_location or not str(spec.origin).endswith(".py"):
        return None
    return Path(spec.origin)


def _only_definition(tree: ast.Module, name: str) -> ast.FunctionDef | None:
    """The module's one top-level ``def name``, when nothing else in the module binds ``name``."""
    bindings = [node for node in ast.walk(tree) if _bound_names(node) & {name, "*"}]
    if len(bindings) == 1 and bindings[0] in tree.body and isinstance(bindings[0], ast.FunctionDef):
        return bindings[0]
    return None


def _bound_names(node: ast.AST) -> set[str]:
    """The names ``node`` binds (``*`` for a star import, which may bind any)."""
    if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
        return {node.name}
    if isinstance(node, ast.Name) and not isinstance(node.ctx, ast.Load):
        return {node.id}
    if isinstance(node, ast.alias):
        return {node.asname or node.name.split(".")[0]}
    if isinstance(node, ast.ExceptHandler) and node.name:
        return {node.name}
    if isinstance(node, ast.Global | ast.Nonlocal):
        return set(node.names)
    return set()


def _click_names(tree: ast.Module) -> dict[str, str]:
    """Names under which the module's top-level imports bind click and its command decorators: the module
    (``click`` -> ``""``) and ``from click import command`` (``command`` -> ``command``)."""
    names: dict[str, str] = {}
    for node in tree.body:
        if isinstance(node, ast.Import):
            names.update({alias.asname or alias.name: "" for alias in node.names if alias.name == "click"})
        elif isinstance(node, ast.ImportFrom) and node.module == "click" and not node.level:
            names.update(
                {alias.asname or alias.name: alias.name for alias in node.names if alias.name in _DECORATORS}
            )
    return names


def _stand_in(name: str, function: ast.FunctionDef, click_names: dict[str, str]) -> click.Command | None:
    decorator = function.decorator_list[0]
    call = decorator if isinstance(decorator, ast.Call) else None
    kind = _decorator_kind(call.func if call else decorator, click_names)
    if kind is None or (call and (len(call.args) > 1 or any(k.arg in (None, "cls") for k in call.keywords))):
        return None
    shown: dict[str, object] = {}
    for keyword in call.keywords if call else ():
        if keyword.arg in _SHOWN:
            try:
                value = ast.literal_eval(keyword.value)
            except (ValueError, TypeError, RecursionError):  # computed, not written out
                return None
            if value is not None and not isinstance(value, _SHOWN[keyword.arg]):
                return None
            if value is not None:
                shown[keyword.arg] = value
    if "help" not in shown:
        shown["help"] = _docstring(function)
    return _DECORATORS[kind](name, **shown)


def _decorator_kind(node: ast.expr, click_names: dict[str, str]) -> str | None:
    """``command`` or ``group`` when ``node`` is click's decorator of that name, else None."""
    if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name):
        if click_names.get(node.value.id) == "" and node.attr in _DECORATORS:
            return node.attr
    if isinstance(node, ast.Name) and click_names.get(node.id):
        return click_names[node.id]
    return None


def _docstring(function: ast.FunctionDef) -> str | None:
    """The function's ``__doc__``: the docstring as written; cleaned from Python 3.13 on, whose compiler
    strips its indentation."""
    return ast.get_docstring(function, clean=sys.version_info >= (3, 13))
