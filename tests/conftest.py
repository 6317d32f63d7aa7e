"""Fixtures shared by every test package."""

from __future__ import annotations

import pytest

import rigs


@pytest.fixture(scope="session")
def faceunits() -> rigs.Rig:
    """The real CC0 Face Units ARKit-52 rig, from the user cache (`harness rigs fetch faceunits`; CI fetches
    it before the tests)."""
    try:
        return rigs.load_faceunits(download=False)
    except rigs.RigError as error:
        pytest.skip(f"Face Units rig not in the user cache (run `harness rigs fetch faceunits`): {error}")
