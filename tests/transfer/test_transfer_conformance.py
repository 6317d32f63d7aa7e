"""Every installed transfer method passes `transfer.testing`'s checks, and the checks catch broken ones."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

import transfer
from transfer import Transfer
from transfer.testing import CHECKS, check_transfer, parametrize_with_checks


@parametrize_with_checks([transfer.get(name) for name in transfer.names()])
def test_every_installed_method_conforms(method, check):
    check(method)


@dataclass(frozen=True)
class _Copy(Transfer):
    """The template's own deltas array, returned as is."""

    name = "test-copy"
    uses_examples = False

    def transfer(self, inputs):
        return inputs.template.deltas


@dataclass(frozen=True)
class _Absolute(Transfer):
    """Absolute positions of the target's shapes instead of deltas: wrong under translation."""

    name = "test-absolute"
    uses_examples = False

    def transfer(self, inputs):
        return inputs.template.deltas + 2 * inputs.target_neutral - inputs.template.neutral


@dataclass(frozen=True)
class _Noisy(Transfer):
    """Different on every call."""

    name = "test-noisy"

    def transfer(self, inputs):
        return inputs.template.deltas + np.random.default_rng().normal(0, 1e-3, inputs.template.deltas.shape)


def test_check_transfer_runs_every_check_and_names_them():
    assert check_transfer(transfer.get("delta")) == list(CHECKS)


@pytest.mark.parametrize(
    ("method", "failing"),
    [(_Copy(), "output"), (_Absolute(), "identity"), (_Noisy(), "identity")],
    ids=["aliases-the-template", "absolute-positions", "random"],
)
def test_the_checks_catch_a_broken_method(method, failing):
    with pytest.raises(AssertionError, match=f"check '{failing}'"):
        check_transfer(method)
