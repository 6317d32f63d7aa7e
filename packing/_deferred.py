"""Values computed on first read: what a restricted problem (`PackingProblem.restrict`) and an expression of
the sequence (`Expression.clique_rows`) derive only when someone asks."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any


class Deferred:
    """A value computed on first read, once."""

    def __init__(self, compute: Callable[[], Any]) -> None:
        self._compute: Callable[[], Any] | None = compute
        self._value: Any = None

    def value(self) -> Any:
        """The value, computed on the first call (the function is then let go, with what it held)."""
        if self._compute is not None:
            self._value, self._compute = self._compute(), None
        return self._value


def computed(value: Any) -> Any:
    """The value of a `Deferred`, or ``value`` itself."""
    return value.value() if isinstance(value, Deferred) else value


class DeferredField:
    """A dataclass field that may be set to a `Deferred`; the value is computed on first read and kept (the
    instance dictionary holds it under another name, so a frozen dataclass can still fill it in).

    A class with such fields pickles its instances with `computed_state` (a `Deferred` holds a function,
    which does not pickle)."""

    def __set_name__(self, owner: type, name: str) -> None:
        self.name, self.slot = name, f"_{name}_value"

    def __get__(self, instance: Any, owner: type | None = None) -> Any:
        if instance is None:
            raise AttributeError(self.name)  # (no default value for the dataclass)
        value = instance.__dict__[self.slot]
        if isinstance(value, Deferred):
            value = value.value()
            instance.__dict__[self.slot] = value
        return value

    def __set__(self, instance: Any, value: Any) -> None:
        instance.__dict__[self.slot] = value


def computed_state(instance: Any) -> dict[str, Any]:
    """The instance dictionary of ``instance`` with every deferred value computed (for ``__getstate__``)."""
    return {name: computed(value) for name, value in instance.__dict__.items()}
