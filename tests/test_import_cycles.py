"""The modules of one package import each other without a loop: each module can be read, tested and moved
knowing only the modules below it, and which module is imported first never decides whether a name exists.

Every import counts: at the top, inside a function, under ``if TYPE_CHECKING:``, relative or absolute, and
``importlib.import_module`` of a constant name. ``from pkg import name`` is an edge to the submodule
``pkg.name`` when there is one, else to the module the package's lazy loader loads for ``name`` (its
``__init__.pyi``, `lazy_loader.attach_stub`), else to the package's ``__init__``. A lazy table itself is not
an import: ``__init__`` loads its entries only when a name is used, so it adds no edge from ``__init__``; the
imports an ``__init__`` writes out count like any other.
"""

from __future__ import annotations

import ast
from pathlib import Path

import networkx as nx
import pytest

from tests.test_package_graph import ORDER, ROOT

#: At most this many cycles are listed per package (a dense loop has very many).
SHOWN = 50


def module_name(path: Path, root: Path) -> str:
    """The dotted name of the module at ``path`` under ``root`` (``rigs`` for ``rigs/__init__.py``)."""
    parts = path.relative_to(root).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def lazy_table(package: str, root: Path = ROOT) -> dict[str, str]:
    """The module of each name a package's lazy loader attaches: the ``from .module import name`` lines of
    its ``__init__.pyi`` (`lazy_loader.attach_stub`)."""
    stub = root / package / "__init__.pyi"
    if not stub.exists():
        return {}
    return {
        alias.name: f"{package}.{node.module}"
        for node in ast.parse(stub.read_text(), str(stub)).body
        if isinstance(node, ast.ImportFrom) and node.level == 1 and node.module
        for alias in node.names
    }


def imported_modules(
    path: Path, here: str, package: str, modules: set[str], lazy: dict[str, str]
) -> set[str]:
    """The modules of ``package`` (``modules``) that the module ``here`` (at ``path``) imports anywhere."""
    # what a relative import of level 1 is relative to: the package of the module (itself for an __init__)
    base = here if path.name == "__init__.py" else here.rpartition(".")[0]
    found = set()

    def add_from(source: str, names: list[str]) -> None:
        for name in names:
            if f"{source}.{name}" in modules:
                found.add(f"{source}.{name}")
            elif source == package and name in lazy:
                found.add(lazy[name])
            elif source in modules:
                found.add(source)

    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names if alias.name in modules)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                source = base.rsplit(".", node.level - 1)[0] if node.level > 1 else base
                source = f"{source}.{node.module}" if node.module else source
            else:
                source = node.module or ""
            add_from(source, [alias.name for alias in node.names])
        elif isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "import_module" and node.args:
            if isinstance(node.args[0], ast.Constant) and node.args[0].value in modules:
                found.add(node.args[0].value)
    return found - {here}


def import_graph(package: str, root: Path = ROOT) -> nx.DiGraph:
    """The imports between the modules of ``package`` under ``root``: importer to imported."""
    names = {path: module_name(path, root) for path in sorted((root / package).rglob("*.py"))}
    modules = set(names.values())
    lazy = lazy_table(package, root)
    graph = nx.DiGraph()
    graph.add_nodes_from(modules)
    for path, name in names.items():
        graph.add_edges_from(
            (name, target) for target in imported_modules(path, name, package, modules, lazy)
        )
    return graph


def cycles(graph: nx.DiGraph) -> list[list[str]]:
    """Up to `SHOWN` import loops of ``graph``, each from its smallest module name, shortest first."""
    found = []
    for cycle in nx.simple_cycles(graph):
        start = cycle.index(min(cycle))
        found.append(cycle[start:] + cycle[:start])
        if len(found) == SHOWN:
            break
    return sorted(found, key=lambda cycle: (len(cycle), cycle))


@pytest.mark.parametrize("package", ORDER)
def test_the_modules_of_a_package_import_each_other_without_a_loop(package: str) -> None:
    graph = import_graph(package)
    assert graph.number_of_nodes() > 1, f"no modules in {package}"
    loops = cycles(graph)
    for loop in loops:
        print(" -> ".join([*loop, loop[0]]))
    assert loops == []


def test_the_graph_sees_every_kind_of_import(tmp_path: Path) -> None:
    package = tmp_path / "pkg"
    package.mkdir()
    (package / "__init__.py").write_text(
        "import lazy_loader\n__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)\n"
    )
    (package / "__init__.pyi").write_text("from ._lazy import Lazy as Lazy\n")
    (package / "_a.py").write_text(
        "from typing import TYPE_CHECKING\n"
        "from . import _b\n"
        "from ._c import x\n"
        "if TYPE_CHECKING:\n"
        "    from pkg._d import y\n"
        "def f():\n"
        "    import pkg._e\n"
        "    from pkg import _f, Lazy\n"
        "    return importlib.import_module('pkg._g')\n"
    )
    for name in ("_b", "_c", "_d", "_e", "_f", "_g", "_lazy"):
        (package / f"{name}.py").write_text("")
    graph = import_graph("pkg", tmp_path)
    assert sorted(graph.successors("pkg._a")) == [
        f"pkg.{name}" for name in ("_b", "_c", "_d", "_e", "_f", "_g", "_lazy")
    ]
    assert list(graph.successors("pkg")) == []
    assert cycles(graph) == []
    (package / "_b.py").write_text("from pkg._c import x\n")
    (package / "_c.py").write_text("from . import _a\n")
    assert cycles(import_graph("pkg", tmp_path)) == [["pkg._a", "pkg._c"], ["pkg._a", "pkg._b", "pkg._c"]]
