"""Stop signals: Ctrl-C (SIGINT) and SIGTERM both end a command the same way, and a `KeyboardInterrupt`
that no signal raised (a plugin's own) is told apart from the user's.

`handle_stop_signals` makes both signals raise `KeyboardInterrupt` in the main thread, so that every
clean-up written for Ctrl-C (staged files discarded, ``run.json`` marked ``interrupted``, workers
stopped) runs for SIGTERM too; `stop_signal` tells which one arrived.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator
from types import FrameType

#: The signals that stop a command.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)

_received: list[signal.Signals] = []


def _stop(number: int, frame: FrameType | None) -> None:
    _received.append(signal.Signals(number))
    raise KeyboardInterrupt


@contextlib.contextmanager
def handle_stop_signals() -> Iterator[None]:
    """While in the block, SIGINT and SIGTERM raise `KeyboardInterrupt` and are remembered
    (`stop_signal`); the earlier handlers are put back after it. Only in the main thread."""
    _received.clear()
    earlier = {number: signal.signal(number, _stop) for number in STOP_SIGNALS}
    try:
        yield
    finally:
        for number, handler in earlier.items():
            if handler is not None:  # (None: a handler not set from Python, which cannot be put back)
                signal.signal(number, handler)


def stop_signal() -> signal.Signals | None:
    """The first stop signal received inside `handle_stop_signals`, None when none arrived."""
    return _received[0] if _received else None


def raised_without_signal() -> bool:
    """Whether the `KeyboardInterrupt` being handled was raised by code (a plugin's own), not by a stop
    signal: known inside `handle_stop_signals`, and where Ctrl-C is ignored or left to the system (a
    solver worker process); under any other handler (Python's default one) every one counts as the user's."""
    handler = signal.getsignal(signal.SIGINT)
    if handler is _stop:
        return not _received
    return handler in (signal.SIG_IGN, signal.SIG_DFL)


@contextlib.contextmanager
def stop_signals_deferred() -> Iterator[None]:
    """A block a stop signal cannot cut short: one that arrives in it is delivered (to the handler in place
    before) as the block ends. Only the main thread receives signals; elsewhere this does nothing."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    arrived: list[int] = []

    def defer(number: int, frame: FrameType | None) -> None:
        arrived.append(number)

    earlier = {
        number: signal.signal(number, defer)
        for number in STOP_SIGNALS
        if signal.getsignal(number) is not None  # (a handler not set from Python is left alone)
    }
    try:
        yield
    finally:
        for number, handler in earlier.items():
            signal.signal(number, handler)
        for number in dict.fromkeys(arrived):
            signal.raise_signal(number)
