"""Headless Chromium for the tests of HTML pages: the binary (`.ci/run` installs Debian's ``chromium``), the
flags that keep it off the network and out of the user's profile, and one call of it."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--hide-scrollbars",
)


def chromium_binary() -> str:
    """Path of ``chromium`` (or ``chromium-browser``); the calling test skips without it."""
    found = next(
        (shutil.which(name) for name in ("chromium", "chromium-browser") if shutil.which(name)), None
    )
    if found is None:
        pytest.skip("headless Chromium is not installed (apt-get install chromium, as .ci/run does)")
    return found


def run_chromium(page: Path, profile: Path, *options: str) -> str:
    """Run Chromium on ``page`` with ``options`` (``--dump-dom``, ``--print-to-pdf=...``) and a fresh
    profile folder; its standard output."""
    command = [chromium_binary(), *FLAGS, f"--user-data-dir={profile}", *options, page.as_uri()]
    return subprocess.run(command, capture_output=True, text=True, timeout=120, check=True).stdout
