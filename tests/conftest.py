"""Fixtures shared by every test package, and the Hypothesis profile of the run.

Under continuous integration (``CI`` set, as `.ci/run` and hosted CI services set it) the property tests
draw the same examples on every machine and every run (``derandomize``), so that a verdict of the gate is
reproducible and a red run never comes from a draw no one can repeat; elsewhere each run draws new ones.
A failure prints the blob that replays it (``print_blob``).
"""

from __future__ import annotations

import os

import pytest
from hypothesis import settings

import rigs

settings.register_profile("ci", derandomize=True, print_blob=True)
settings.register_profile("dev", print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci" if os.environ.get("CI") else "dev"))


@pytest.fixture(scope="session")
def faceunits() -> rigs.Rig:
    """The real CC0 Face Units ARKit-52 rig, from the user cache (`harness rigs fetch faceunits`; CI fetches
    it before the tests)."""
    try:
        return rigs.load_faceunits(download=False)
    except rigs.RigError as error:
        pytest.skip(f"Face Units rig not in the user cache (run `harness rigs fetch faceunits`): {error}")
