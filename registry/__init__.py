"""Plugin registries: entry-point discovery and availability, one implementation for every kind of plugin.

Solvers (``harness.solvers``), transfer methods (``harness.transfers``) and ``harness`` subcommands
(``harness.commands``) are each a `PluginRegistry`: names from installed metadata without importing a
plugin, a plugin loaded on first use, a load failure or a missing attribute listed as unavailable with the
reason, a name registered twice warned about, and an `Availability` for every plugin. This package
imports nothing else of the project, so every package may use it.
"""

from registry._availability import Availability, AvailabilityStatus, package_availability
from registry._registry import (
    PluginInfo,
    PluginRegistry,
    PluginUnavailableError,
    UnknownPluginError,
    collect,
    missing_attributes,
)

__all__ = [
    "Availability",
    "AvailabilityStatus",
    "PluginInfo",
    "PluginRegistry",
    "PluginUnavailableError",
    "UnknownPluginError",
    "collect",
    "missing_attributes",
    "package_availability",
]
