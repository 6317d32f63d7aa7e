"""Conformance checks of a plugin kind, run one after another or one per pytest case (scikit-learn's
``parametrize_with_checks``): the mechanism `solvers.testing` and `transfer.testing` share."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from typing import Any

#: A conformance check: ``check(plugin, seed)`` returns nothing and raises `AssertionError` on a failure.
Check = Callable[..., None]


def run_checks(checks: Mapping[str, Check], plugin: Any, seed: int = 0) -> list[str]:
    """Run every check on ``plugin`` in order; the names of those that ran.

    Raises
    ------
    AssertionError
        On the first failed check, its message prefixed with ``check 'NAME': ``.
    """
    for name, check in checks.items():
        try:
            check(plugin, seed)
        except AssertionError as error:
            raise AssertionError(f"check {name!r}: {error}") from None
    return list(checks)


def parametrize_checks(
    checks: Mapping[str, Check], plugins: Iterable[Any], argument: str, name_of: Callable[[Any], str]
):
    """A ``pytest.mark.parametrize`` of ``(argument, "check")`` over every (plugin, check) pair, each case
    named ``PLUGIN-CHECK`` with ``name_of(plugin)``."""
    import pytest

    plugins = list(plugins)
    cases = [(plugin, check) for plugin in plugins for check in checks.values()]
    ids = [f"{name_of(plugin)}-{name}" for plugin in plugins for name in checks]
    return pytest.mark.parametrize((argument, "check"), cases, ids=ids)
