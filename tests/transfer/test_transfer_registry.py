"""The plugin registry: names, lookup, parameters."""

from __future__ import annotations

import subprocess
import sys
from importlib.metadata import entry_points

import pytest

import transfer
from transfer import Transfer

EXPECTED = {
    "delta": "DeltaTransfer",
    "dt": "DeformationTransfer",
    "ebfr": "ExampleBasedRigging",
    "ebfr-full": "ExampleBasedRiggingFull",
    "plbs": "PatchwiseBlendshapes",
}


def test_names_lists_every_builtin_method():
    assert set(EXPECTED) <= set(transfer.names())
    assert transfer.names() == sorted(transfer.names())


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_get_returns_the_plugin_with_its_entry_point_name(name):
    method = transfer.get(name)
    assert isinstance(method, Transfer)
    assert type(method).__name__ == EXPECTED[name]
    assert method.name == name
    points = {point.name: point.value for point in entry_points(group="harness.transfers")}
    assert points[name].endswith(":" + EXPECTED[name])


def test_get_passes_parameters_and_keeps_defaults():
    method = transfer.get("ebfr", beta=0.5)
    assert method.beta == 0.5
    assert method.kappa == 0.1 and method.theta == 2.0


def test_unknown_method_lists_installed_ones():
    with pytest.raises(ValueError, match=r"unknown transfer method 'nope'; valid names: .*ebfr"):
        transfer.get("nope")


def test_unknown_parameter_lists_accepted_ones():
    with pytest.raises(ValueError, match=r"'ebfr' has no parameter bta; accepted: .*beta"):
        transfer.get("ebfr", bta=1.0)


@pytest.mark.parametrize(
    ("name", "params", "message"),
    [
        ("ebfr", {"beta": 0.0}, r"beta must be a finite number > 0, got 0.0"),
        ("ebfr", {"beta": float("nan")}, r"beta must be a finite number > 0"),
        ("ebfr", {"kappa": -1.0}, r"kappa must be a finite number > 0"),
        ("ebfr", {"motion_scale": "metres"}, r"motion_scale must be 'peak' or 'absolute', got 'metres'"),
        ("dt", {"static_tolerance": -1e-3}, r"static_tolerance must be a finite number >= 0"),
        ("plbs", {"n_patches": 0}, r"n_patches must be a positive integer, got 0"),
        ("plbs", {"blend_rings": 1.5}, r"blend_rings must be an integer, got 1.5"),
        ("plbs", {"lambda_reg": 0.0}, r"lambda_reg must be a finite number > 0"),
        ("ebfr-full", {"iterations": 0}, r"iterations must be a positive integer, got 0"),
        ("ebfr-full", {"beta_schedule": (0.5,)}, r"beta_schedule must be \(first, last\)"),
        ("ebfr-full", {"gamma_schedule": (100.0, -1.0)}, r"gamma_schedule must be a finite number > 0"),
    ],
)
def test_bad_parameter_values_are_refused(name, params, message):
    with pytest.raises(ValueError, match=message):
        transfer.get(name, **params)


def test_importing_the_package_and_its_plugins_leaves_scipy_and_rigs_unloaded():
    """``import transfer`` and `transfer.get` stay cheap: what needs scipy or the rigs imports it on use."""
    script = (
        "import sys, transfer\n"
        "[transfer.get(name) for name in transfer.names()]\n"
        "print(sorted({m.split('.')[0] for m in sys.modules} & {'scipy', 'rigs', 'pandas'}))\n"
    )
    found = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True)
    assert found.stdout.strip() == "[]"
