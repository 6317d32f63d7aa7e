"""Plugin registries: entry-point discovery and availability, one implementation for every kind of plugin.

Solvers (``harness.solvers``), transfer methods (``harness.transfers``) and ``harness`` subcommands
(``harness.commands``) are each a `PluginRegistry`: names from installed metadata without importing a plugin,
a plugin loaded on first use, a load failure or a missing attribute listed as unavailable with the reason, a
name registered twice warned about, and an `Availability` for every plugin. Beside them, what every package
shares: `HarnessError`, the error type of bad input, a plugin's declared settings (`Setting`), the stop
signals (`handle_stop_signals`), the running of
a plugin kind's conformance checks (`run_checks`), the one cache type (`BoundedMemo`), the one file writer
(`atomic_write`: every file the project writes goes through it) and the output folders built on it (`claim`).
This package imports nothing else of the project, so every package may use it.
"""

from registry._atomic import (
    append_text,
    atomic_path,
    atomic_write,
    move_apart,
    staged_target,
    swap_folder,
    sync_file,
    sync_folders,
    write_new,
)
from registry._availability import Availability, AvailabilityStatus, package_availability
from registry._checks import parametrize_checks, run_checks
from registry._errors import HarnessError
from registry._memo import BoundedMemo
from registry._outdir import OutputFolder, OutputFolderError, check_apart, claim, reopen
from registry._plugin_settings import SETTING_TYPES, Setting, checked_settings, declared_settings
from registry._registry import (
    PluginInfo,
    PluginRegistry,
    PluginUnavailableError,
    UnknownPluginError,
    collect,
    missing_attributes,
)
from registry._stop import (
    STOP_SIGNALS,
    handle_stop_signals,
    raised_without_signal,
    stop_signal,
    stop_signals_deferred,
)

__all__ = [
    "SETTING_TYPES",
    "STOP_SIGNALS",
    "Availability",
    "AvailabilityStatus",
    "BoundedMemo",
    "HarnessError",
    "OutputFolder",
    "OutputFolderError",
    "PluginInfo",
    "PluginRegistry",
    "PluginUnavailableError",
    "Setting",
    "UnknownPluginError",
    "append_text",
    "atomic_path",
    "atomic_write",
    "check_apart",
    "checked_settings",
    "claim",
    "collect",
    "declared_settings",
    "handle_stop_signals",
    "missing_attributes",
    "move_apart",
    "package_availability",
    "parametrize_checks",
    "raised_without_signal",
    "reopen",
    "run_checks",
    "staged_target",
    "stop_signal",
    "stop_signals_deferred",
    "swap_folder",
    "sync_file",
    "sync_folders",
    "write_new",
]
