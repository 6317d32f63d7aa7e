"""Durations on the command line: ``30s``, ``2m``, ``500ms``, ``1h``, or plain seconds."""

from __future__ import annotations

import re

from registry import HarnessError

#: Longest duration accepted (a week): waits on worker processes overflow near 596 hours (a 32-bit count of
#: milliseconds), and so do the time limits of some solver libraries.
LONGEST_DURATION = 7 * 24 * 3600.0
_UNITS = {"ms": 0.001, "s": 1.0, "m": 60.0, "min": 60.0, "h": 3600.0}
_PATTERN = re.compile(r"^\s*(?P<value>\d+(?:\.\d*)?|\.\d+)\s*(?P<unit>ms|s|min|m|h)?\s*$")


def parse_duration(text: str) -> float:
    """Seconds in a duration such as ``30s``, ``2m``, ``500ms``, ``1.5h`` or ``90`` (seconds).

    Parameters
    ----------
    text : str
        A non-negative number with an optional unit: ``ms``, ``s``, ``m`` / ``min``, ``h``.

    Returns
    -------
    float
        The duration in seconds.

    Raises
    ------
    HarnessError
        When ``text`` is not a duration (the message shows the accepted forms), or is longer than
        `LONGEST_DURATION`.

    Examples
    --------
    >>> parse_duration("2m"), parse_duration("500ms"), parse_duration("30")
    (120.0, 0.5, 30.0)
    """
    match = _PATTERN.match(str(text))
    if match is None:
        raise HarnessError(f"not a duration: {text!r} (use e.g. 30s, 2m, 500ms, 1h or plain seconds)")
    seconds = float(match["value"]) * _UNITS[match["unit"] or "s"]
    if seconds > LONGEST_DURATION:
        raise HarnessError(
            f"duration {text!r} is longer than {LONGEST_DURATION / 3600:.0f}h, the longest a limit may be "
            "(the operating system's waits and some solvers' limits overflow beyond it)"
        )
    return seconds


def format_duration(seconds: float) -> str:
    """Short human form of a duration: ``850ms``, ``12.3s``, ``4m05s``."""
    if seconds < 1:
        return f"{seconds * 1000:.0f}ms"
    if seconds < 60:
        return f"{seconds:.1f}s"
    minutes, rest = divmod(int(round(seconds)), 60)
    return f"{minutes}m{rest:02d}s"
