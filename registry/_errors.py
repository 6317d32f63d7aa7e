"""The project's error type for bad input and refused requests.

Every package raises `HarnessError` (or a subclass: `rigs.RigError`, `registry.OutputFolderError`,
`UnknownPluginError`, ...) where the user gave something wrong: a malformed file, an unknown name, an
option out of range, an output folder that may not be used. Its message is one line naming the file,
field or option and what is wrong, which the ``harness`` command prints as it is. Any other exception is a
fault of the program and is reported as such (a short traceback and where to report it).
"""

from __future__ import annotations


class HarnessError(ValueError):
    """Bad input or a refused request, with a one-line message for the user (naming the file, field or
    option, and what is wrong). A `ValueError`, so that library callers catching that keep working."""
