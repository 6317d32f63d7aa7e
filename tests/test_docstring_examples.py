"""The examples in the packages' docstrings run, and print what they say (`doctest`)."""

from __future__ import annotations

import doctest
import importlib
import pkgutil
from pathlib import Path

import pytest

from tests.test_package_graph import ORDER


def _modules_with_examples() -> list[str]:
    """Every module of the project's packages whose source holds a ``>>>`` example."""
    found = []
    for package in ORDER:
        path = importlib.import_module(package).__path__
        for module in pkgutil.iter_modules(path, prefix=f"{package}."):
            source = Path(module.module_finder.path, module.name.rpartition(".")[2] + ".py")
            if source.is_file() and ">>> " in source.read_text(encoding="utf-8"):
                found.append(module.name)
    return found


@pytest.mark.parametrize("name", _modules_with_examples())
def test_the_examples_of_a_module_run_as_written(name: str) -> None:
    module = importlib.import_module(name)
    finder = doctest.DocTestFinder()
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    for test in finder.find(module):
        runner.run(test)
    results = runner.summarize(verbose=False)
    assert results.attempted > 0 or "+SKIP" in Path(module.__file__).read_text(encoding="utf-8")
    assert results.failed == 0, f"{name}: {results.failed} of {results.attempted} examples failed"
