"""Data flows one way through the packages: a module imports only its own package and those before it in
`ORDER` (an import that runs back up is a design bug)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

#: The packages in the direction data flows.
ORDER = ("registry", "rigs", "packing", "solvers", "transfer", "render", "harness", "session", "reports")
ROOT = Path(__file__).resolve().parent.parent


def imported_packages(path: Path) -> set[str]:
    """The project packages ``path`` imports anywhere (at the top, in functions, under TYPE_CHECKING)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found.update(alias.name.partition(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.add(node.module.partition(".")[0])
        elif isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "import_module" and node.args:
            if isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str):
                found.add(node.args[0].value.partition(".")[0])
    return found & set(ORDER)


@pytest.mark.parametrize("package", ORDER)
def test_a_package_imports_only_those_before_it(package: str) -> None:
    allowed = set(ORDER[: ORDER.index(package) + 1])
    modules = sorted((ROOT / package).rglob("*.py"))
    assert modules, f"no modules in {package}"
    upward = {
        str(path.relative_to(ROOT)): sorted(imported_packages(path) - allowed)
        for path in modules
        if imported_packages(path) - allowed
    }
    assert upward == {}


def test_the_order_names_every_package_of_the_distribution() -> None:
    packages = {path.parent.name for path in ROOT.glob("*/__init__.py") if path.parent.name != "tests"}
    assert packages == set(ORDER)


def private_imports(path: Path, package: str) -> list[str]:
    """Modules of other project packages that ``path`` imports by a private name (``rigs._obj``)."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        names = [alias.name for alias in node.names] if isinstance(node, ast.Import) else []
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module]
        for name in names:
            top, _, rest = name.partition(".")
            if top in ORDER and top != package and rest.startswith("_"):
                found.append(name)
    return found


@pytest.mark.parametrize("package", ORDER)
def test_a_package_uses_the_others_by_their_public_names(package: str) -> None:
    private = {
        str(path.relative_to(ROOT)): private_imports(path, package)
        for path in sorted((ROOT / package).rglob("*.py"))
        if private_imports(path, package)
    }
    assert private == {}
