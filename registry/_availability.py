"""Whether a plugin can run here, and if not, why (Pyomo's ``Availability`` idea).

Every plugin (a solver, a transfer method) answers ``availability()`` cheaply, without importing its
backend library; `package_availability` does that for a backend that one Python distribution provides.
"""

from __future__ import annotations

import enum
import importlib.metadata
import importlib.util
from dataclasses import dataclass


class AvailabilityStatus(enum.StrEnum):
    """Whether a plugin can run here, and if not, why."""

    AVAILABLE = "available"
    MISSING_PACKAGE = "missing_package"
    MISSING_BINARY = "missing_binary"
    VERSION_MISMATCH = "version_mismatch"
    LOAD_ERROR = "load_error"


@dataclass(frozen=True)
class Availability:
    """Result of a plugin's ``availability()``: truthy when it can run, else falsy with the reason.

    Attributes
    ----------
    status : AvailabilityStatus
        Available, or which kind of problem prevents it.
    version : str
        Backend version that would run (empty when unknown).
    reason : str
        Human-readable explanation of an unavailable status, including how to fix it.
    """

    status: AvailabilityStatus
    version: str = ""
    reason: str = ""

    def __bool__(self) -> bool:
        return self.status is AvailabilityStatus.AVAILABLE

    @classmethod
    def available(cls, version: str = "") -> Availability:
        """The plugin can run; ``version`` names the backend that would."""
        return cls(AvailabilityStatus.AVAILABLE, version)

    @classmethod
    def missing_package(cls, distribution: str, hint: str = "") -> Availability:
        """A required Python distribution is not installed."""
        reason = f"package {distribution!r} is not installed" + (f"; {hint}" if hint else "")
        return cls(AvailabilityStatus.MISSING_PACKAGE, reason=reason)

    @classmethod
    def missing_binary(cls, binary: str, hint: str = "") -> Availability:
        """A required executable was not found."""
        reason = f"executable {binary!r} was not found" + (f"; {hint}" if hint else "")
        return cls(AvailabilityStatus.MISSING_BINARY, reason=reason)

    @classmethod
    def version_mismatch(cls, version: str, reason: str) -> Availability:
        """The installed backend version cannot run here."""
        return cls(AvailabilityStatus.VERSION_MISMATCH, version, reason)

    @classmethod
    def load_error(cls, error: BaseException | str) -> Availability:
        """The plugin itself failed to load or to report its availability."""
        text = error if isinstance(error, str) else f"{type(error).__name__}: {error}"
        return cls(AvailabilityStatus.LOAD_ERROR, reason=text)


def package_availability(distribution: str, module: str | None = None, hint: str = "") -> Availability:
    """Availability of a backend provided by one Python distribution, without importing it.

    Parameters
    ----------
    distribution : str
        Distribution name as installed (``importlib.metadata``), e.g. ``"highspy"``.
    module : str, optional
        Top-level module it provides, when it differs from ``distribution``.
    hint : str
        How to install it, appended to the reason when missing.
    """
    try:
        version = importlib.metadata.version(distribution)
    except importlib.metadata.PackageNotFoundError:
        return Availability.missing_package(distribution, hint or f"pip install {distribution}")
    try:
        spec = importlib.util.find_spec(module or distribution)
    except (ImportError, ValueError) as error:
        return Availability.load_error(error)
    if spec is None:
        return Availability.missing_package(
            distribution, f"module {module or distribution!r} is not importable"
        )
    return Availability.available(version)
