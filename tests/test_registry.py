"""One plugin registry for every kind (`registry.PluginRegistry`): solvers, transfer methods and commands
share discovery, load errors, availability and the duplicate-name warning."""

from __future__ import annotations

import importlib.metadata

import pytest

import registry
import transfer
from transfer import _registry as transfer_registry


@pytest.fixture
def fake_transfers():
    def install(*specs: tuple[str, str]) -> None:
        points = [
            importlib.metadata.EntryPoint(name, value, transfer_registry.GROUP) for name, value in specs
        ]
        transfer_registry.TRANSFERS.refresh()
        transfer_registry.TRANSFERS.__dict__["_points"] = registry.collect(points, "transfer method")

    yield install
    transfer_registry.TRANSFERS.refresh()


def test_a_transfer_method_has_an_availability_and_a_version():
    found = transfer.availability("ebfr")
    assert found and found.version
    (info,) = transfer.info(["ebfr"])
    assert info.available and info.plugin.__name__ == "ExampleBasedRigging"
    assert info.as_dict()["entry_point"] == "transfer.ebfr:ExampleBasedRigging"


def test_a_broken_transfer_plugin_is_listed_unavailable_with_the_reason(fake_transfers):
    fake_transfers(
        ("broken", "no_such_module_anywhere:Method"),
        ("imposter", "transfer.ebfr:RiggingSettings"),
        ("renamed", "transfer.ebfr:ExampleBasedRigging"),
        ("dt", "transfer.deformation:DeformationTransfer"),
    )
    assert transfer.names() == ["broken", "dt", "imposter", "renamed"]
    assert not transfer.availability("broken")
    assert "cannot load no_such_module_anywhere:Method" in transfer.availability("broken").reason
    assert "is not a transfer.Transfer subclass" in transfer.availability("imposter").reason
    assert "declares name 'ebfr', registered as 'renamed'" in transfer.availability("renamed").reason
    assert transfer.availability("dt")
    with pytest.raises(registry.PluginUnavailableError, match="transfer method 'broken' is unavailable"):
        transfer.get("broken")


def test_a_name_registered_twice_warns_for_every_kind():
    points = [
        importlib.metadata.EntryPoint("dt", "transfer.deformation:DeformationTransfer", "harness.transfers"),
        importlib.metadata.EntryPoint("dt", "other:Transfer", "harness.transfers"),
    ]
    with pytest.warns(RuntimeWarning, match="transfer method 'dt' is registered twice"):
        found = registry.collect(points, "transfer method")
    assert found["dt"].value == "transfer.deformation:DeformationTransfer"


def test_a_plugin_whose_availability_raises_is_unavailable_not_an_error(monkeypatch):
    import solvers
    from solvers.greedy import GreedySolver

    def explode(cls):
        raise OSError("licence server unreachable")

    monkeypatch.setattr(GreedySolver, "availability", classmethod(explode))
    found = solvers.availability("greedy")
    assert not found and "licence server unreachable" in found.reason
