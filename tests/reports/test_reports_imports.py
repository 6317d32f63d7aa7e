"""`reports` and `reports.cli` import nothing heavy: ``harness --help`` imports the commands to list them."""

from __future__ import annotations

import subprocess
import sys

import pytest

import reports

HEAVY = ("pandas", "matplotlib", "numpy", "pyarrow", "rich", "harness._records")

_PROBE = f"""
import sys
import reports, reports.cli
heavy = [name for name in {HEAVY!r} if name in sys.modules]
private = sorted(name for name in sys.modules if name.startswith("reports._") and name != "reports._layout")
print(heavy, private)
"""


def test_the_package_and_its_commands_import_only_click():
    done = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "[] []"


def test_public_names_resolve_on_first_use():
    for name in reports.__all__:
        assert getattr(reports, name) is not None, name
    assert set(reports.__all__) <= set(dir(reports))
    assert reports.compare.__module__ == "reports._compare"
    with pytest.raises(AttributeError, match="No reports attribute nothing"):
        _ = reports.nothing
